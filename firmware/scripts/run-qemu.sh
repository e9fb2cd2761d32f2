#!/usr/bin/env bash
# Run the firmware ELF under QEMU's Zynq-7000 model and propagate its exit status.
#
# Usage: scripts/run-qemu.sh [options] <elf> [input-file]
#        scripts/run-qemu.sh --board [options] <elf | raw binary>
#   --plan FILE      put a plan of any method (its canonical bytes: 80 for FSM, 32 or 96 for a
#                    baseline) into the plan mailbox at 0x03FFFF08 with the descriptor
#                    {"PLAN", length} at 0x03FFFF00 (src/layout.rs)
#   --icount         instruction-count mode: `-icount shift=$ICOUNT_SHIFT` (default 4) and tell
#                    the firmware the shift (descriptor "ICNT" at 0x03FFFFE8), so that it prints
#                    exact instruction counts (`BENCH ... instructions=N`). See src/icount.rs.
#   --selftest NAME  make the firmware take a failure path instead of its work:
#                    panic (exit 101), abort (data abort, 102), undef (102), exit:N (N)
#   --timeout SECS   kill QEMU after SECS seconds (default $QEMU_TIMEOUT or 60): exit code 124
#   --trace FILE     also log every executed instruction's PC (-d exec,nochain + -singlestep)
#                    to FILE, for an independent instruction count (slow, large)
#   --serve-uart PORT  serve the host protocol on a UART for ever (descriptor {"UART", index}
#                    at 0x03FFFFD8): the UART's bytes go through QEMU's UART model to a TCP
#                    server on 127.0.0.1:PORT (`-serial tcp:...,server=on,wait=off`), where
#                    `fsm camera info --device tcp://127.0.0.1:PORT` talks to the firmware.
#                    One host at a time; the next connects when it leaves. No input file,
#                    --plan or --selftest. No time-out unless --timeout is given; without
#                    one QEMU replaces this script (exec): killing its PID stops QEMU.
#   --serve-net PORT serve the host protocol over Ethernet for ever (descriptor {"NET ", 0, ...}
#                    at 0x03FFFFC0: GEM0, TCP/IP at 10.0.2.15/24, port 7070): QEMU's GEM model
#                    on user networking (`-nic user,model=cadence_gem,restrict=on,hostfwd=...`)
#                    forwards 127.0.0.1:PORT to 10.0.2.15:7070, where
#                    `fsm camera info --device tcp://127.0.0.1:PORT` talks to the firmware.
#                    restrict=on: the guest reaches nothing but QEMU's own slirp. Same rules
#                    as --serve-uart (no input, exec, no time-out unless --timeout).
#   --uart N         with --serve-uart: UART0 (QEMU's first -serial, 0xE0000000) or UART1
#                    (the second, 0xE0001000; the ZedBoard's USB-UART). Default 1.
#   --board          start the image as a board does, with no debugger: no semihosting, so the
#                    firmware's console is UART1 (on this script's stdout) and it serves over
#                    Ethernet (GEM0 on user networking; with --serve-net PORT forwarded from
#                    127.0.0.1:PORT to --guest). The image is the ELF or a raw binary
#                    (scripts/image-arm.sh's fsm-firmware.bin), which is loaded at
#                    --load-address and started there with the CPU's PC set to it, as U-Boot's
#                    `go` does. A reset of the SoC ends QEMU (-no-reboot) unless --reboot.
#                    No input file, --plan or --serve-uart; no descriptor but --selftest's
#                    and --word's.
#   --guest A:P      with --board --serve-net: the firmware's address and port (default
#                    10.0.2.15:7070, its default without a NET descriptor)
#   --load-address A with --board and a raw binary: where it goes and starts (0x00100000)
#   --word ADDR=VAL  write the 32-bit word VAL at ADDR before the CPU starts (what U-Boot's
#                    `mw.l ADDR VAL` does); repeatable
#   --reboot         with --board: let a reset of the SoC restart the image
#   --defmt FILE     with --board: UART0 (QEMU's first -serial), where the firmware writes its
#                    defmt frames when no semihosting host answers, into FILE (decode it with
#                    `defmt-print -e <elf> < FILE`)
#
# The input file (at most 64 MiB) is placed raw at 0x04000000 with QEMU's generic loader and
# its length in the descriptor {"FSMI", length} at 0x03FFFFF0 (src/layout.rs).
# The firmware's console output (semihosting; with --board UART1) goes to stdout, this script's
# and QEMU's own messages to stderr. Semihosting file paths (fw-candidates.bin, defmt.bin) are relative to the
# current directory.
# Exit status: QEMU's, i.e. the firmware's semihosting exit code (0 = success, 101 = panic,
# 102 = CPU exception), 124 on timeout. With --serve-uart or --serve-net the firmware never exits: QEMU runs
# until it is killed. With --board there is no exit code to give: QEMU ends with 0 when the
# firmware resets the SoC (a panic, an exception, a self-test's exit), which its console says.
set -euo pipefail

QEMU="${QEMU:-qemu-system-arm}"
TIMEOUT="${QEMU_TIMEOUT:-60}"
ICOUNT=0
SHIFT="${ICOUNT_SHIFT:-4}"
SELFTEST=""
TRACE=""
PLAN=""
SERVE_PORT=""
NET_PORT=""
UART_INDEX=1
TIMEOUT_GIVEN=0
BOARD=0
GUEST=""
LOAD_ADDR=0x00100000
REBOOT=0
DEFMT_FILE=""
WORDS=()

usage() { sed -n '2,60p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }

while [ $# -gt 0 ]; do
    case "$1" in
        --icount) ICOUNT=1 ;;
        --plan) [ $# -ge 2 ] || usage; PLAN="$2"; shift ;;
        --selftest) [ $# -ge 2 ] || usage; SELFTEST="$2"; shift ;;
        --timeout) [ $# -ge 2 ] || usage; TIMEOUT="$2"; TIMEOUT_GIVEN=1; shift ;;
        --serve-uart) [ $# -ge 2 ] || usage; SERVE_PORT="$2"; shift ;;
        --serve-net) [ $# -ge 2 ] || usage; NET_PORT="$2"; shift ;;
        --uart) [ $# -ge 2 ] || usage; UART_INDEX="$2"; shift ;;
        --board) BOARD=1 ;;
        --guest) [ $# -ge 2 ] || usage; GUEST="$2"; shift ;;
        --load-address) [ $# -ge 2 ] || usage; LOAD_ADDR="$2"; shift ;;
        --word) [ $# -ge 2 ] || usage; WORDS+=("$2"); shift ;;
        --reboot) REBOOT=1 ;;
        --defmt) [ $# -ge 2 ] || usage; DEFMT_FILE="$2"; shift ;;
        --trace) [ $# -ge 2 ] || usage; TRACE="$2"; shift ;;
        -h|--help) usage ;;
        --) shift; break ;;
        -*) echo "run-qemu: unknown option $1" >&2; usage ;;
        *) break ;;
    esac
    shift
done
[ $# -ge 1 ] && [ $# -le 2 ] || usage
ELF="$1"
INPUT="${2:-}"
[ -f "$ELF" ] || { echo "run-qemu: no such ELF: $ELF" >&2; exit 2; }
command -v "$QEMU" >/dev/null || { echo "run-qemu: $QEMU not found: run scripts/install-toolchain.sh" >&2; exit 2; }

# Mailbox addresses: keep in sync with src/layout.rs and src/icount.rs.
INPUT_ADDR=0x04000000
INPUT_MAX=$((0x04000000))
INPUT_DESC=0x03fffff0
ICOUNT_DESC=0x03ffffe8
SELFTEST_DESC=0x03ffffe0
PLAN_DESC=0x03ffff00
UART_DESC=0x03ffffd8
NET_DESC=0x03ffffc0
PLAN_BYTES=0x03ffff08
MAGIC_FSMI=0x494d5346   # "FSMI"
MAGIC_ICNT=0x544e4349   # "ICNT"
MAGIC_TEST=0x54534554   # "TEST"
MAGIC_PLAN=0x4e414c50   # "PLAN"
MAGIC_UART=0x54524155   # "UART"
MAGIC_NET=0x2054454e    # "NET "
NET_GUEST=10.0.2.15     # layout::NetConfig::DEFAULT
NET_GUEST_PORT=7070     # fsm_protocol::DEFAULT_TCP_PORT

word() { # addr value: one little-endian u32 written by QEMU's generic loader
    printf -- '-device\nloader,addr=%s,data=%s,data-len=4\n' "$1" "$2"
}

# The first -serial is UART0, the second UART1 (QEMU's xilinx_zynq.c).
serial=(-serial null)
if [ -n "$SERVE_PORT" ]; then
    case "$SERVE_PORT" in ''|*[!0-9]*) echo "run-qemu: --serve-uart PORT must be a number" >&2; exit 2 ;; esac
    [ "$SERVE_PORT" -ge 1 ] && [ "$SERVE_PORT" -le 65535 ] || { echo "run-qemu: port $SERVE_PORT is not 1..65535" >&2; exit 2; }
    [ -z "$INPUT" ] && [ -z "$PLAN" ] && [ -z "$SELFTEST" ] \
        || { echo "run-qemu: --serve-uart takes no input file, --plan or --selftest" >&2; exit 2; }
    tcp="tcp:127.0.0.1:$SERVE_PORT,server=on,wait=off"
    case "$UART_INDEX" in
        0) serial=(-serial "$tcp" -serial null) ;;
        1) serial=(-serial null -serial "$tcp") ;;
        *) echo "run-qemu: --uart must be 0 or 1" >&2; exit 2 ;;
    esac
fi

nic=()
if [ "$BOARD" = 1 ]; then
    [ -z "$INPUT" ] && [ -z "$PLAN" ] && [ -z "$SERVE_PORT" ] \
        || { echo "run-qemu: --board takes no input file, --plan or --serve-uart" >&2; exit 2; }
    guest="${GUEST:-$NET_GUEST:$NET_GUEST_PORT}"
    case "$guest" in *:*) ;; *) echo "run-qemu: --guest wants ADDRESS:PORT, not $guest" >&2; exit 2 ;; esac
    fwd=""
    if [ -n "$NET_PORT" ]; then
        case "$NET_PORT" in ''|*[!0-9]*) echo "run-qemu: --serve-net PORT must be a number" >&2; exit 2 ;; esac
        fwd=",hostfwd=tcp:127.0.0.1:$NET_PORT-${guest%:*}:${guest##*:}"
    fi
    # UART1 (the second -serial) is the console: stdout; UART0 (the first) the defmt frames.
    # GEM0 is always there, as on a board.
    if [ -n "$DEFMT_FILE" ]; then
        serial=(-serial "file:$DEFMT_FILE" -serial stdio)
    else
        serial=(-serial null -serial stdio)
    fi
    nic=(-nic "user,model=cadence_gem,restrict=on$fwd")
elif [ -n "$GUEST" ] || [ "$REBOOT" = 1 ] || [ -n "$DEFMT_FILE" ]; then
    echo "run-qemu: --guest, --reboot and --defmt go with --board" >&2; exit 2
elif [ -n "$NET_PORT" ]; then
    case "$NET_PORT" in ''|*[!0-9]*) echo "run-qemu: --serve-net PORT must be a number" >&2; exit 2 ;; esac
    [ "$NET_PORT" -ge 1 ] && [ "$NET_PORT" -le 65535 ] || { echo "run-qemu: port $NET_PORT is not 1..65535" >&2; exit 2; }
    [ -z "$INPUT" ] && [ -z "$PLAN" ] && [ -z "$SELFTEST" ] && [ -z "$SERVE_PORT" ] \
        || { echo "run-qemu: --serve-net takes no input file, --plan, --selftest or --serve-uart" >&2; exit 2; }
    # The first -nic is GEM0 (0xE000B000, QEMU's xilinx_zynq.c).
    nic=(-nic "user,model=cadence_gem,restrict=on,hostfwd=tcp:127.0.0.1:$NET_PORT-$NET_GUEST:$NET_GUEST_PORT")
fi

# `-semihosting` alone would print the firmware's console output on QEMU's stderr (QEMU 7.2);
# routing it through a stdio chardev puts it on stdout, leaving stderr to QEMU and this script.
args=(-M xilinx-zynq-a9 -nographic -monitor none "${serial[@]}" "${nic[@]}")
if [ "$BOARD" = 0 ]; then
    args+=(-chardev stdio,id=semihost -semihosting-config enable=on,target=native,chardev=semihost)
elif [ "$REBOOT" = 0 ]; then
    args+=(-no-reboot)
fi

for w in ${WORDS[@]+"${WORDS[@]}"}; do
    case "$w" in *=*) ;; *) echo "run-qemu: --word wants ADDR=VALUE, not $w" >&2; exit 2 ;; esac
    mapfile -t -O "${#args[@]}" args < <(word "${w%%=*}" "${w#*=}")
done

if [ -n "$SERVE_PORT" ]; then
    mapfile -t -O "${#args[@]}" args < <(word "$UART_DESC" "$MAGIC_UART"; word "$((0x03ffffdc))" "$UART_INDEX")
fi

if [ -n "$NET_PORT" ] && [ "$BOARD" = 0 ]; then
    # {"NET ", port 0 (default), address 0 (default 10.0.2.15/24 via 10.0.2.2), 0, 0}
    mapfile -t -O "${#args[@]}" args < <(word "$NET_DESC" "$MAGIC_NET"; word "$((0x03ffffc4))" 0;
        word "$((0x03ffffc8))" 0; word "$((0x03ffffcc))" 0; word "$((0x03ffffd0))" 0)
fi

if [ -n "$INPUT" ]; then
    [ -f "$INPUT" ] || { echo "run-qemu: no such input file: $INPUT" >&2; exit 2; }
    len=$(stat -c %s "$INPUT")
    [ "$len" -le "$INPUT_MAX" ] || { echo "run-qemu: input is $len bytes, more than $INPUT_MAX" >&2; exit 2; }
    case "$INPUT" in *,*) echo "run-qemu: input path must not contain a comma" >&2; exit 2 ;; esac
    args+=(-device "loader,file=$INPUT,addr=$INPUT_ADDR,force-raw=on")
    mapfile -t -O "${#args[@]}" args < <(word "$INPUT_DESC" "$MAGIC_FSMI"; word "$((0x03fffff4))" "$len")
fi

if [ -n "$PLAN" ]; then
    [ -f "$PLAN" ] || { echo "run-qemu: no such plan file: $PLAN" >&2; exit 2; }
    plan_len="$(stat -c %s "$PLAN")"
    case "$plan_len" in
        80|32|96) ;;
        *) echo "run-qemu: plan file $PLAN is $plan_len bytes, not a plan's 80 (FSM), 32 or 96 (baselines) (fsm plan --wire)" >&2; exit 2 ;;
    esac
    case "$PLAN" in *,*) echo "run-qemu: plan path must not contain a comma" >&2; exit 2 ;; esac
    args+=(-device "loader,file=$PLAN,addr=$PLAN_BYTES,force-raw=on")
    mapfile -t -O "${#args[@]}" args < <(word "$PLAN_DESC" "$MAGIC_PLAN"; word "$((0x03ffff04))" "$plan_len")
fi

if [ "$ICOUNT" = 1 ]; then
    args+=(-icount "shift=$SHIFT")
    mapfile -t -O "${#args[@]}" args < <(word "$ICOUNT_DESC" "$MAGIC_ICNT"; word "$((0x03ffffec))" "$SHIFT")
fi

if [ -n "$SELFTEST" ]; then
    case "$SELFTEST" in
        panic) req=1 ;;
        abort) req=2 ;;
        undef) req=3 ;;
        exit:*) n="${SELFTEST#exit:}"; [ "$n" -ge 1 ] && [ "$n" -le 255 ] || usage; req=$((0x100 + n)) ;;
        *) usage ;;
    esac
    mapfile -t -O "${#args[@]}" args < <(word "$SELFTEST_DESC" "$MAGIC_TEST"; word "$((0x03ffffe4))" "$req")
fi

if [ -n "$TRACE" ]; then
    # QEMU 7.2 calls one-instruction-per-TB `-singlestep` (later: -accel tcg,one-insn-per-tb=on).
    args+=(-singlestep -d exec,nochain -D "$TRACE")
fi

if [ "$BOARD" = 1 ] && [ "$(head -c 4 "$ELF" | od -A n -t x1 | tr -d ' ')" != 7f454c46 ]; then
    # A raw binary: loaded at its address, the CPU started there (U-Boot's `go`).
    case "$ELF" in *,*) echo "run-qemu: image path must not contain a comma" >&2; exit 2 ;; esac
    args+=(-device "loader,file=$ELF,addr=$LOAD_ADDR,force-raw=on" -device "loader,addr=$LOAD_ADDR,cpu-num=0")
else
    args+=(-kernel "$ELF")
fi

if [ -n "$SERVE_PORT" ] && [ "$TIMEOUT_GIVEN" = 0 ]; then
    echo "run-qemu: serving on UART$UART_INDEX at tcp://127.0.0.1:$SERVE_PORT" >&2
    exec "$QEMU" "${args[@]}" </dev/null
fi
if [ -n "$NET_PORT" ] && [ "$TIMEOUT_GIVEN" = 0 ]; then
    echo "run-qemu: serving over Ethernet (GEM0) at tcp://127.0.0.1:$NET_PORT -> ${guest:-$NET_GUEST:$NET_GUEST_PORT}" >&2
    exec "$QEMU" "${args[@]}" </dev/null
fi

start=$(date +%s%N)
set +e
timeout --kill-after=5 "$TIMEOUT" "$QEMU" "${args[@]}" </dev/null
rc=$?
set -e
ms=$(( ($(date +%s%N) - start) / 1000000 ))
if [ "$rc" = 124 ]; then
    echo "run-qemu: TIMEOUT after ${TIMEOUT}s" >&2
fi
echo "run-qemu: exit code $rc, wall time ${ms} ms" >&2
exit "$rc"
