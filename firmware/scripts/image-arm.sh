#!/usr/bin/env bash
# Build what a user puts on a Zynq-7000 board (ZedBoard and the like) to run the firmware
# without a debugger, into one folder:
#
#   fsm-firmware.elf          the image (for JTAG, or the second partition of a BOOT.BIN)
#   fsm-firmware.bin          the same image, raw: load it at its load address and jump there
#                             (the first word is the reset vector, a branch to _start)
#   boot.cmd, boot.scr        U-Boot commands that load fsm-firmware.bin from the SD card,
#                             write the camera's Ethernet settings and start it; boot.scr is
#                             boot.cmd made by `mkimage -T script` (u-boot-tools), which
#                             U-Boot's distro boot runs by itself from the SD card
#   fsm-firmware-zedboard.cfg OpenOCD commands that load the ELF over JTAG and start it
#   boot.bif                  bootgen's recipe for an SD-card / QSPI BOOT.BIN
#   BOOT.BIN                  with --fsbl only: the board's first-stage boot loader, then the
#                             firmware (xilinx-bootgen)
#   image.txt                 load address, entry, sizes and the Ethernet settings
#
# Without a debugger the firmware's console is UART1 (115,200 baud 8N1) and it serves the host
# protocol over Ethernet (firmware/README.md, "On a board").
#
# Usage: scripts/image-arm.sh [options]
#   --out DIR        where to write (default: <firmware>/target/images)
#   --elf FILE       package this ELF instead of building one (scripts/build-arm.sh)
#   --address A/P    the camera's IPv4 address and prefix length (default 192.168.1.10/24), or
#                    `dhcp`: address, prefix and route leased from the network's DHCP server
#   --gateway A      its default route (default: none; not with dhcp)
#   --port N         the protocol's TCP port (default 7070)
#   --fsbl FILE      the board's FSBL ELF (from Vitis, for the board's hardware design): also
#                    make BOOT.BIN with bootgen
# Prints the folder as the last line: `FW_IMAGES=<dir>`.
set -euo pipefail

FW_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="$FW_DIR/target/images"
ELF=""
ADDRESS="192.168.1.10/24"
GATEWAY=""
PORT=7070
FSBL=""

usage() { sed -n '2,31p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
while [ $# -gt 0 ]; do
    case "$1" in
        --out) [ $# -ge 2 ] || usage; OUT="$2"; shift ;;
        --elf) [ $# -ge 2 ] || usage; ELF="$2"; shift ;;
        --address) [ $# -ge 2 ] || usage; ADDRESS="$2"; shift ;;
        --gateway) [ $# -ge 2 ] || usage; GATEWAY="$2"; shift ;;
        --port) [ $# -ge 2 ] || usage; PORT="$2"; shift ;;
        --fsbl) [ $# -ge 2 ] || usage; FSBL="$2"; shift ;;
        -h|--help) usage ;;
        *) echo "image-arm: unknown argument $1" >&2; usage ;;
    esac
    shift
done

# ipv4 A.B.C.D -> the u32 the descriptor holds (a << 24 | b << 16 | c << 8 | d), or fail.
ipv4() {
    local IFS=. a b c d
    read -r a b c d extra <<<"$1"
    for o in "$a" "$b" "$c" "$d"; do
        case "$o" in ''|*[!0-9]*) return 1 ;; esac
        [ "$o" -le 255 ] || return 1
    done
    [ -z "${extra:-}" ] || return 1
    echo $(( (a << 24) | (b << 16) | (c << 8) | d ))
}
gateway_word=0
if [ "$ADDRESS" = dhcp ]; then
    # The descriptor's address 0xFFFFFFFF asks for DHCP (firmware/src/layout.rs).
    addr=dhcp
    addr_word=4294967295
    prefix=0
    [ -z "$GATEWAY" ] || { echo "image-arm: --gateway goes with a static --address, not dhcp" >&2; exit 2; }
else
    addr="${ADDRESS%/*}"
    prefix=24
    [ "$addr" = "$ADDRESS" ] || prefix="${ADDRESS#*/}"
    addr_word="$(ipv4 "$addr")" || { echo "image-arm: --address $ADDRESS is not A.B.C.D/P or dhcp" >&2; exit 2; }
    case "$prefix" in ''|*[!0-9]*) echo "image-arm: prefix /$prefix is not a number" >&2; exit 2 ;; esac
    [ "$prefix" -ge 1 ] && [ "$prefix" -le 32 ] || { echo "image-arm: prefix /$prefix is not 1..32" >&2; exit 2; }
    [ "$addr_word" != 0 ] && [ "$addr_word" != 4294967295 ] \
        || { echo "image-arm: --address $addr cannot be a camera's address" >&2; exit 2; }
fi
if [ -n "$GATEWAY" ]; then
    gateway_word="$(ipv4 "$GATEWAY")" || { echo "image-arm: --gateway $GATEWAY is not A.B.C.D" >&2; exit 2; }
fi
case "$PORT" in ''|*[!0-9]*) echo "image-arm: --port $PORT is not a number" >&2; exit 2 ;; esac
[ "$PORT" -ge 1 ] && [ "$PORT" -le 65535 ] || { echo "image-arm: --port $PORT is not 1..65535" >&2; exit 2; }
if [ -n "$FSBL" ]; then
    [ -f "$FSBL" ] || { echo "image-arm: no such FSBL: $FSBL" >&2; exit 2; }
    command -v bootgen >/dev/null || { echo "image-arm: --fsbl needs bootgen (Debian: apt-get install xilinx-bootgen)" >&2; exit 2; }
fi

if [ -z "$ELF" ]; then
    log="$(mktemp)"
    trap 'rm -f "$log"' EXIT
    "$FW_DIR/scripts/build-arm.sh" >"$log" 2>&1 || { cat "$log" >&2; exit 1; }
    ELF="$(sed -n 's/^FW_ELF=//p' "$log" | tail -n1)"
fi
[ -f "$ELF" ] || { echo "image-arm: no such ELF: $ELF" >&2; exit 2; }

# rust-objcopy ships with rustup's toolchains (beside rust-lld, which build-arm.sh links with);
# it needs its toolchain's libLLVM. GNU objcopy on an x86 host does not read ARM ELFs.
find_objcopy() {
    local home="${RUSTUP_HOME:-$HOME/.rustup}" c
    for c in "$home"/toolchains/stable-*/lib/rustlib/*/bin/rust-objcopy \
             "$home"/toolchains/*/lib/rustlib/*/bin/rust-objcopy; do
        if [ -x "$c" ]; then
            echo "$c"
            return 0
        fi
    done
    command -v llvm-objcopy || return 1
}
OBJCOPY="$(find_objcopy)" || { echo "image-arm: no rust-objcopy under ${RUSTUP_HOME:-$HOME/.rustup}/toolchains, no llvm-objcopy" >&2; exit 1; }
objcopy() { LD_LIBRARY_PATH="${OBJCOPY%/lib/rustlib/*}/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" "$OBJCOPY" "$@"; }

# Where the image goes: the lowest physical address of a loaded segment (link.x's RAM origin).
# The raw binary spans the loaded segments from there; .bss and the stacks are not in it
# (_start zeroes .bss).
load_hex="$(LC_ALL=C readelf -lW "$ELF" | awk '$1 == "LOAD" { print $4 }' | sort | head -n1)"
[ -n "$load_hex" ] || { echo "image-arm: $ELF has no loadable segment" >&2; exit 1; }
load=$((load_hex))
entry_hex="$(LC_ALL=C readelf -hW "$ELF" | awk '/Entry point address/ { print $4 }')"

rm -rf "$OUT.partial"
mkdir -p "$OUT.partial"
cp "$ELF" "$OUT.partial/fsm-firmware.elf"
objcopy -O binary "$ELF" "$OUT.partial/fsm-firmware.bin"
bin_len=$(stat -c %s "$OUT.partial/fsm-firmware.bin")
# The first word must be the reset vector, an ARM `b` (condition AL: 0xEA......), so that a
# jump to the load address starts the firmware.
first="$(od -A n -t x4 -N 4 "$OUT.partial/fsm-firmware.bin" | tr -d ' ')"
case "$first" in ea*) ;; *) echo "image-arm: fsm-firmware.bin starts with $first, not a branch (the reset vector)" >&2; exit 1 ;; esac
version="$(sed -n 's/^version *= *"\(.*\)"/\1/p' "$FW_DIR/Cargo.toml" | head -n1)"
load_str="$(printf '0x%08x' "$load")"

# The "NET " descriptor (firmware/src/layout.rs, NET_DESC_ADDR): magic, port, address, prefix,
# gateway, as five little-endian words at 0x03ffffc0.
words=(0x2054454e "$PORT" "$addr_word" "$prefix" "$gateway_word")
notes=('"NET "' "TCP port $PORT" "address $addr" "prefix /$prefix" "gateway ${GATEWAY:-none}")
[ "$addr" != dhcp ] || notes[2]="address 0xffffffff: ask a DHCP server"
{
    echo "# fsm-firmware $version, started by U-Boot on a Zynq-7000 board (firmware/scripts/image-arm.sh)."
    if [ "$addr" = dhcp ]; then
        echo "# Console: UART1, 115200 8N1; its SERVE NET line gives the leased address A. Then: fsm camera info --device tcp://A:$PORT"
    else
        echo "# Console: UART1, 115200 8N1. Then: fsm camera info --device tcp://$addr:$PORT"
    fi
    echo "setenv fsm_load $load_str"
    echo "# From the SD card's first partition (or over TFTP: tftpboot \${fsm_load} fsm-firmware.bin)"
    echo "fatload mmc 0 \${fsm_load} fsm-firmware.bin"
    echo "# The camera's Ethernet settings: the NET descriptor at 0x03ffffc0 (firmware/src/layout.rs)"
    for i in 0 1 2 3 4; do
        echo "# ${notes[$i]}"
        printf 'mw.l 0x%08x 0x%08x\n' $((0x03ffffc0 + 4 * i)) "${words[$i]}"
    done
    echo "# The firmware starts with the MMU and caches off: \"dcache off\" cleans L1 and L2 first"
    echo "dcache off"
    echo "icache off"
    echo "go \${fsm_load}"
} >"$OUT.partial/boot.cmd"
if command -v mkimage >/dev/null; then
    mkimage -A arm -O linux -T script -C none -n "fsm-firmware $version" \
        -d "$OUT.partial/boot.cmd" "$OUT.partial/boot.scr" >/dev/null
else
    echo "image-arm: no mkimage (Debian: apt-get install u-boot-tools): boot.scr not made" >&2
fi

cat >"$OUT.partial/fsm-firmware-zedboard.cfg" <<EOF
# OpenOCD: load fsm-firmware.elf into a ZedBoard over its USB-JTAG and start it.
#   openocd -f board/digilent_zedboard.cfg -f fsm-firmware-zedboard.cfg
# DDR must be working first: let the board boot its FSBL (or U-Boot) from the SD card, or
# source Vivado's ps7_init.tcl and call ps7_init before this script.
# With "arm semihosting enable" (before resume) the firmware uses OpenOCD's console and exits
# like under QEMU; without it, it is a camera on its own (console on UART1, Ethernet at the
# address of the NET descriptor, or 10.0.2.15/24: write the descriptor with the mww lines of
# boot.cmd's mw.l lines before resume).
init
halt
# The L2 cache (PL310) off, then the MMU and L1 caches off (SCTLR M, C, I): the image goes to
# DDR itself, and _start expects the MMU off.
mww 0xf8f02100 0
arm mcr 15 0 1 0 0 [expr {[arm mrc 15 0 1 0 0] & ~0x1005}]
load_image fsm-firmware.elf
verify_image fsm-firmware.elf
resume $load_str
EOF

cat >"$OUT.partial/boot.bif" <<EOF
// bootgen recipe for a Zynq-7000 BOOT.BIN (SD card or QSPI):
//   bootgen -arch zynq -image boot.bif -o BOOT.BIN -w on
// fsbl.elf is the board's first-stage boot loader, made by Vitis from the board's hardware
// design: it sets up clocks, DDR and the MIO pins (UART1, Ethernet) that the firmware relies
// on, then loads fsm-firmware.elf to its addresses and starts it at _start.
the_ROM_image:
{
    [bootloader] fsbl.elf
    fsm-firmware.elf
}
EOF
if [ -n "$FSBL" ]; then
    cp "$FSBL" "$OUT.partial/fsbl.elf"
    (cd "$OUT.partial" && bootgen -arch zynq -image boot.bif -o BOOT.BIN -w on >/dev/null)
    rm "$OUT.partial/fsbl.elf"
fi

{
    echo "fsm-firmware $version for armv7a-none-eabihf (Zynq-7000 Cortex-A9)"
    echo "fsm-firmware.bin: $bin_len bytes, load address $load_str, entry $load_str (reset vector; _start at $entry_hex)"
    if [ "$addr" = dhcp ]; then
        echo "Ethernet: address, prefix and route by DHCP, port $PORT (boot.cmd's NET descriptor)"
    else
        echo "Ethernet: $addr/$prefix port $PORT gateway ${GATEWAY:-none} (boot.cmd's NET descriptor)"
    fi
    echo "console: UART1 115200 8N1"
} >"$OUT.partial/image.txt"

# Whole or not at all: the folder replaces the previous one once every file is in it.
rm -rf "$OUT"
mv "$OUT.partial" "$OUT"
cat "$OUT/image.txt"
echo "FW_IMAGES=$OUT"
