#!/usr/bin/env bash
# End-to-end check of the bare-metal firmware, the one entry point `.ci/run` calls: install what
# is missing, build the ARM ELF, cross-check its candidates against the host's decode under
# QEMU (bit-identical, BFSM and two-group EFSM, 32 rows with interreflections, on the firmware's
# own mirror scene and on the simulator's plane_mirror, with CLEAN and with the local-maximum
# search; the four baselines, phase shift, Micro Phase Shifting, Code Ensemble and line scanning,
# on the mirror scene), drive it with the host CLI over its UART and its Ethernet (`fsm upload`,
# `fsm camera info`, `fsm camera scan`; every method's plan over Ethernet, Code Ensemble's over the
# UART too), boot scripts/image-arm.sh's raw binary as U-Boot would, with no debugger
# (console on UART1, scans over Ethernet, a panic that resets the SoC), check how it refuses bad
# input, the determinism of its instruction counts, every failure path's exit code, the Rust
# cross-check test, and (if defmt-print is installed) defmt logging.
# Non-interactive. Ends with the line `N passed, M failed` and exits non-zero if anything failed.
#
# Environment: FW_SKIP_INSTALL=1 to skip scripts/install-toolchain.sh;
#              FW_WITH_DEFMT_PRINT=1 to also install defmt-print if missing (a few minutes);
#              FW_SKIP_DEFMT=1 to skip the defmt build and decode (skipped anyway, with a
#              note, when defmt-print is not installed).
set -euo pipefail

FW_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
S="$FW_DIR/scripts"
HOST_CARGO="$(command -v cargo || true)"   # rustup's cargo, for the host build (before PATH games)

if [ "${FW_SKIP_INSTALL:-0}" != 1 ]; then
    if [ "${FW_WITH_DEFMT_PRINT:-0}" = 1 ]; then
        "$S/install-toolchain.sh" --with-defmt-print
    else
        "$S/install-toolchain.sh"
    fi
fi

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); echo "ok   - $*"; }
bad() { fail=$((fail + 1)); echo "FAIL - $*"; }
# A free TCP port of 127.0.0.1 (another process could take it before QEMU does: QEMU then
# fails and the step that needs it says so).
free_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}
# await_line PATTERN FILE: waits up to 30 s for a line matching PATTERN in FILE (a console
# QEMU writes; the caller then checks the line itself).
await_line() {
    for _ in $(seq 150); do
        grep -q "$1" "$2" && return
        sleep 0.2
    done
}

build_log="$WORK/build.log"
if ! "$S/build-arm.sh" >"$build_log" 2>&1; then
    cat "$build_log"
    bad "build-arm.sh"
    echo "$pass passed, $fail failed"
    exit 1
fi
grep -A20 '^ *text' "$build_log" || true
BUILT_ELF="$(sed -n 's/^FW_ELF=//p' "$build_log" | tail -n1)"
cp "$BUILT_ELF" "$WORK/fsm-firmware.elf"
ELF="$WORK/fsm-firmware.elf"
ok "build-arm.sh -> $(basename "$ELF")"

# Host tools (scene, decode, compare): the workspace tests' build, which links both binaries
# (fsm-firmware, fsm) with the features `cargo test --workspace` resolves, so after that
# command nothing is rebuilt (`cargo build -p X --bin Y` resolves fewer features and rebuilt
# 17 crates, about 2 minutes per binary, measured here).
"$HOST_CARGO" test -q --manifest-path "$FW_DIR/../Cargo.toml" --workspace --no-run
TARGET_DIR="$("$HOST_CARGO" metadata --format-version 1 --no-deps --manifest-path "$FW_DIR/Cargo.toml" \
    | python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')"
TOOL="$TARGET_DIR/debug/fsm-firmware"

cd "$WORK"

# 1. Without input: prints its limits and exits 0.
set +e
"$S/run-qemu.sh" "$ELF" >run1.txt 2>&1
rc=$?
set -e
cat run1.txt
if [ "$rc" = 0 ] && grep -q '^INPUT none' run1.txt && grep -q 'rows up to 4096 pixels' run1.txt; then
    ok "no input: limits printed, exit 0"
else
    bad "no input: exit code $rc"
fi

# 2. The cross-check: Cortex-A9 candidates == host candidates, byte for byte.
if FW_ELF="$ELF" "$S/crosscheck-arm.sh" --rows 32 --width 48 >crosscheck.txt 2>&1; then
    cat crosscheck.txt
    ok "crosscheck-arm.sh: BFSM and EFSM (2 groups), 32 rows x 48 pixels, and PS, MPS, CE, LS (128 columns), 16 rows x 48 pixels, replay and protocol session, bit-identical"
else
    cat crosscheck.txt
    bad "crosscheck-arm.sh"
fi

# 2a. Rows of a real camera: 4096 pixels, decoded in slices (src/scan.rs), BFSM and two-group
#     EFSM, replay and protocol session, bit-identical with the host's decode of the whole row.
if FW_ELF="$ELF" "$S/crosscheck-arm.sh" --rows 2 --width 4096 --methods "bfsm efsm2" \
    >crosscheck-wide.txt 2>&1; then
    grep -E '^(identical|ok)' crosscheck-wide.txt
    ok "crosscheck-arm.sh: rows of 4096 pixels (BFSM and EFSM 2 groups, 2 rows, decoded in slices), bit-identical"
else
    cat crosscheck-wide.txt
    bad "crosscheck-arm.sh --rows 2 --width 4096"
fi

# 2b. The same cross-check on the project's light-transport simulator: `fsm simulate` renders
#     plane_mirror (a diffuse plane lit directly and through a mirror) at 48 x 32 pixels, `fsm plan
#     --wire` gives the plan bytes the firmware takes (built above with the workspace tests).
FSM="$TARGET_DIR/debug/fsm"

# simulate PRESET DIR: plane_mirror at 48 x 32 pixels -> DIR/scan.dump and its wire plan DIR/plan.bin
simulate() {
    "$FSM" simulate --scene plane_mirror --preset "$1" --camera 48x32 --out "$2" >/dev/null \
        && "$FSM" plan --check "$2/plan.toml" --wire "$2/plan.bin" >/dev/null 2>&1
}

# crosscheck_dumps READY NAME WHAT BFSM_DUMP BFSM_PLAN EFSM2_DUMP EFSM2_PLAN: crosscheck-arm.sh on
# these dumps (READY = 1 if they were made), its output in NAME.txt, reported as WHAT.
crosscheck_dumps() {
    if [ "$1" = 1 ] && FW_ELF="$ELF" FW_DUMP_BFSM="$4" FW_PLAN_BFSM="$5" \
        FW_DUMP_EFSM2="$6" FW_PLAN_EFSM2="$7" "$S/crosscheck-arm.sh" --methods "bfsm efsm2" \
        >"$2.txt" 2>&1; then
        grep -E '^(identical|ok)' "$2.txt"
        ok "crosscheck-arm.sh $3: bit-identical"
    else
        cat "$2.txt" 2>/dev/null || true
        bad "crosscheck-arm.sh $3"
    fi
}

sim_ok=1
for p in paper-bfsm paper-efsm-2; do
    simulate "$p" "sim-$p" || sim_ok=0
done
# The baselines' plans for the simulator's 768-column projector, and plane_mirror through them
# (sim-METHOD/), for the camera commands over Ethernet (2e).
BASELINES="phase-shift micro-phase-shift code-ensemble line-scan"
baselines_ok=1
for m in $BASELINES; do
    "$FSM" plan --method "$m" --projector-columns 768 --out "$m.toml" >/dev/null \
        && "$FSM" simulate --scene plane_mirror --plan "$m.toml" --camera 48x32 \
            --out "sim-$m" >/dev/null \
        && "$FSM" plan --check "sim-$m/plan.toml" --wire "sim-$m/plan.bin" >/dev/null 2>&1 \
        || baselines_ok=0
done
crosscheck_dumps "$sim_ok" crosscheck-sim \
    "on fsm simulate plane_mirror (paper BFSM and EFSM 2 groups, 32 rows x 48 pixels)" \
    "$WORK/sim-paper-bfsm/scan.dump" "$WORK/sim-paper-bfsm/plan.bin" \
    "$WORK/sim-paper-efsm-2/scan.dump" "$WORK/sim-paper-efsm-2/plan.bin"

# 2c. The local-maximum search (`ScanPlan::with_local_maxima`, the camera's fast decoder): the
#     firmware's mirror scene with BFSM, the simulator's plane_mirror with two-group EFSM.
fast_ok=1
"$TOOL" scene --plan bfsm-fast --width 48 --rows 32 --dump fast-bfsm.dump --plan-out fast-bfsm.plan \
    >/dev/null || fast_ok=0
simulate paper-efsm-2-fast sim-fast || fast_ok=0
crosscheck_dumps "$fast_ok" crosscheck-fast \
    "with the local-maximum search (BFSM mirror scene, EFSM 2 groups plane_mirror, 32 rows x 48 pixels)" \
    "$WORK/fast-bfsm.dump" "$WORK/fast-bfsm.plan" "$WORK/sim-fast/scan.dump" "$WORK/sim-fast/plan.bin"

# link_scan DEVICE PRESET NAME: `fsm camera scan` of sim-PRESET through DEVICE (the firmware's
# UART or Ethernet) into NAME.cand, compared with the host's decode (32 rows); prints the scan's
# time and rate. Fails if anything differs.
link_scan() {
    local t0 t1 bytes
    t0=$(date +%s.%N)
    "$FSM" camera scan --plan "sim-$2/plan.toml" --dump "sim-$2/scan.dump" --device "$1" \
        --out "$3.cand" --timeout 60 >"$3-scan.txt" 2>&1 || { cat "$3-scan.txt"; return 1; }
    t1=$(date +%s.%N)
    "$TOOL" decode --plan "sim-$2/plan.bin" --dump "sim-$2/scan.dump" --out "$3-host.cand" >/dev/null \
        && "$TOOL" compare "$3-host.cand" "$3.cand" --min-rows 32 >"$3-compare.txt" \
        || { cat "$3-compare.txt" 2>/dev/null; return 1; }
    bytes=$(stat -c %s "sim-$2/scan.dump")
    awk -v a="$t0" -v b="$t1" -v n="$bytes" -v p="$2" \
        'BEGIN { printf "%s: 32 rows, %d bytes of rows in %.2f s: %.1f rows/s, %.0f kB/s\n", p, n, b - a, 32 / (b - a), n / 1000 / (b - a) }'
}

# upload_check DEVICE NAME [PLAN]: `fsm upload` of PLAN (default: the BFSM plan) on its own; the
# camera names the plan by its fingerprint, and `fsm camera info` then reports that plan as
# loaded. Output in NAME-*.txt.
upload_check() {
    local fp
    "$FSM" upload --plan "${3:-sim-paper-bfsm/plan.toml}" --device "$1" >"$2-upload.txt" 2>&1 \
        && fp="$(sed -n 's/.*(fingerprint \([0-9a-f]*\)).*/\1/p' "$2-upload.txt")" && [ -n "$fp" ] \
        && "$FSM" camera info --device "$1" >"$2-loaded.txt" 2>&1 \
        && grep -q "^loaded plan *$fp\$" "$2-loaded.txt" \
        && echo "$fp"
}

# 2d. The host CLI against the firmware serving on its UART (run-qemu.sh --serve-uart: UART1's
#     bytes go to a TCP socket): `fsm camera info`, then `fsm camera scan` of the simulator's
#     plane_mirror dumps (BFSM and two-group EFSM, 32 rows x 48 pixels), each compared with the
#     host's decode. BFSM sends 2.4 MB of rows through the UART: the scan's time and rate are
#     printed.
uart_port="$(free_port)"
"$S/run-qemu.sh" --serve-uart "$uart_port" "$ELF" >uart-console.txt 2>uart-qemu.txt &
uart_qemu=$!   # run-qemu.sh exec's QEMU: this is QEMU's PID
await_line '^SERVE UART1' uart-console.txt
uart_dev="tcp://127.0.0.1:$uart_port"
if [ "$sim_ok" = 1 ] && grep -q '^SERVE UART1' uart-console.txt \
    && "$FSM" camera info --device "$uart_dev" >uart-info.txt 2>&1 \
    && grep -q '^max pixels per row *4096' uart-info.txt; then
    ok "fsm camera info over the firmware's UART (QEMU, $uart_dev)"
else
    cat uart-console.txt uart-qemu.txt uart-info.txt 2>/dev/null || true
    bad "fsm camera info over the firmware's UART"
fi
if [ "$sim_ok" = 1 ] && fp="$(upload_check "$uart_dev" uart)"; then
    ok "fsm upload over the firmware's UART: plan $fp loaded, as fsm camera info reports"
else
    cat uart-upload.txt uart-loaded.txt 2>/dev/null || true
    bad "fsm upload over the firmware's UART"
fi
for p in paper-efsm-2 paper-bfsm; do
    if [ "$sim_ok" = 1 ] && link_scan "$uart_dev" "$p" "uart-$p" >"uart-$p.rate"; then
        cat "uart-$p.rate"
        ok "fsm camera scan over the firmware's UART, $p (32 rows x 48 pixels): candidates bit-identical"
    else
        cat uart-console.txt uart-qemu.txt "uart-$p.rate" 2>/dev/null || true
        bad "fsm camera scan over the firmware's UART, $p"
    fi
done
# One baseline through the UART too (the link does not depend on the method; Code Ensemble's 80
# frames keep it short): uploaded, then scanned, byte for byte as the host decodes it.
if [ "$baselines_ok" = 1 ] && fp="$(upload_check "$uart_dev" uart-ce sim-code-ensemble/plan.toml)" \
    && link_scan "$uart_dev" code-ensemble uart-ce >uart-ce.rate; then
    cat uart-ce.rate
    ok "fsm upload and fsm camera scan over the firmware's UART, code-ensemble (plan $fp, 32 rows x 48 pixels): candidates bit-identical"
else
    cat uart-console.txt uart-ce-upload.txt uart-ce.rate 2>/dev/null || true
    bad "fsm upload and fsm camera scan over the firmware's UART, code-ensemble"
fi
kill "$uart_qemu" 2>/dev/null || true
wait "$uart_qemu" 2>/dev/null || true

# 2e. The same over Ethernet (run-qemu.sh --serve-net: GEM0 on QEMU's user networking,
#     127.0.0.1:PORT forwarded to the firmware's 10.0.2.15:7070, smoltcp's TCP): `fsm camera info`,
#     `fsm camera scan` of the simulator's plane_mirror dumps (BFSM and two-group EFSM, 32 rows x
#     48 pixels) compared with the host's decode; then hosts that misbehave (garbage, a reset
#     mid-frame) and a whole scan again, which must still be byte-identical.
net_port="$(free_port)"
"$S/run-qemu.sh" --serve-net "$net_port" "$ELF" >net-console.txt 2>net-qemu.txt &
net_qemu=$!   # run-qemu.sh exec's QEMU: this is QEMU's PID
await_line '^SERVE NET' net-console.txt
net_dev="tcp://127.0.0.1:$net_port"
net_up=0
grep -q '^SERVE NET 10.0.2.15:7070 ' net-console.txt && net_up=1
if [ "$sim_ok" = 1 ] && [ "$net_up" = 1 ] \
    && "$FSM" camera info --device "$net_dev" >net-info.txt 2>&1 \
    && grep -q '^max pixels per row *4096' net-info.txt; then
    ok "fsm camera info over the firmware's Ethernet (QEMU GEM0, smoltcp, $net_dev): $(head -n1 net-console.txt | cut -c1-60)"
else
    cat net-console.txt net-qemu.txt net-info.txt 2>/dev/null || true
    bad "fsm camera info over the firmware's Ethernet"
fi
if [ "$sim_ok" = 1 ] && [ "$net_up" = 1 ] && fp="$(upload_check "$net_dev" net)"; then
    ok "fsm upload over the firmware's Ethernet: plan $fp loaded, as fsm camera info reports"
else
    cat net-upload.txt net-loaded.txt 2>/dev/null || true
    bad "fsm upload over the firmware's Ethernet"
fi
for p in paper-bfsm paper-efsm-2; do
    if [ "$sim_ok" = 1 ] && [ "$net_up" = 1 ] && link_scan "$net_dev" "$p" "net-$p" >"net-$p.rate"; then
        cat "net-$p.rate"
        ok "fsm camera scan over Ethernet, $p (32 rows x 48 pixels): candidates bit-identical"
    else
        cat "net-$p.rate" 2>/dev/null || true
        bad "fsm camera scan over Ethernet, $p"
    fi
done
# Every baseline's plan: uploaded (the camera acknowledges its fingerprint), then a scan of the
# simulator's plane_mirror through it, compared with the host's decode byte for byte.
for m in $BASELINES; do
    if [ "$baselines_ok" = 1 ] && [ "$net_up" = 1 ] \
        && fp="$(upload_check "$net_dev" "net-$m" "sim-$m/plan.toml")" \
        && link_scan "$net_dev" "$m" "net-$m" >"net-$m.rate"; then
        cat "net-$m.rate"
        ok "fsm upload and fsm camera scan over Ethernet, $m (plan $fp, 32 rows x 48 pixels): candidates bit-identical"
    else
        cat "net-$m-upload.txt" "net-$m.rate" 2>/dev/null || true
        bad "fsm upload and fsm camera scan over Ethernet, $m"
    fi
done
# A host that sends garbage gets an error frame (version 1, Response::Error = tag 6); one that
# sends half a frame and resets the connection (SO_LINGER 0) gets nothing; neither stops the
# server: the next scan is whole and byte-identical.
cat >net-bad.py <<'EOF'
import socket, struct, sys, time
port = int(sys.argv[2])
def cobs_decode(b):
    out, i = bytearray(), 0
    while i < len(b):
        code = b[i]
        out += b[i + 1:i + code]
        i += code
        if code < 0xFF and i < len(b):
            out.append(0)
    return bytes(out)
s = socket.create_connection(("127.0.0.1", port), timeout=10)
if sys.argv[1] == "garbage":
    s.sendall(b"\x00" + bytes(range(1, 256)) * 4 + b"\x00")
    reply = b""
    while reply.count(b"\x00") < 2:
        d = s.recv(4096)
        if not d:
            break
        reply += d
    frame = cobs_decode(reply.strip(b"\x00").split(b"\x00")[0])
    s.close()
    if len(frame) >= 2 and frame[0] == 1 and frame[1] == 6:
        print("garbage answered with an error frame (%d bytes)" % len(reply))
    else:
        sys.exit("garbage: unexpected reply %r" % reply[:64])
else:
    s.sendall(b"\x00" + bytes(range(1, 256)) * 40)   # 10 kB of a frame that never ends
    time.sleep(0.3)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    s.close()
    print("connection reset mid-frame")
EOF
for what in garbage reset; do
    if [ "$net_up" = 1 ] && python3 net-bad.py "$what" "$net_port" >"net-$what.txt" 2>&1; then
        ok "over Ethernet, $(cat "net-$what.txt")"
    else
        cat "net-$what.txt" 2>/dev/null || true
        bad "over Ethernet, bad input: $what"
    fi
done
if [ "$sim_ok" = 1 ] && [ "$net_up" = 1 ] && link_scan "$net_dev" paper-efsm-2 net-again >net-again.rate; then
    cat net-again.rate
    ok "fsm camera scan over Ethernet after garbage and a reset: candidates bit-identical"
else
    cat net-again.rate net-console.txt net-qemu.txt 2>/dev/null || true
    bad "fsm camera scan over Ethernet after garbage and a reset"
fi
kill "$net_qemu" 2>/dev/null || true
wait "$net_qemu" 2>/dev/null || true

# 2f. The board: scripts/image-arm.sh's images; its raw binary started the way U-Boot's `go`
#     starts it (loaded at its load address, the PC there) with no debugger behind it (no
#     semihosting), after the memory writes of its boot.cmd (`mw.l`: the Ethernet settings,
#     here 10.0.2.16/24 port 7071). Console on UART1, `fsm camera info` and `fsm camera scan`
#     over Ethernet byte-identical to the host's decode (BFSM and two-group EFSM); the same image
#     made with `--address dhcp` takes QEMU's DHCP lease and answers over it; then a panic:
#     reported on UART1, the SoC reset (which ends QEMU under -no-reboot), and booted again when
#     QEMU lets the reset restart it.
images="$WORK/images"
images_ok=0
if "$S/image-arm.sh" --elf "$ELF" --out "$images" --address 10.0.2.16/24 --gateway 10.0.2.2 \
        --port 7071 >images.txt 2>&1 \
    && [ -s "$images/fsm-firmware.bin" ] && [ -s "$images/fsm-firmware-zedboard.cfg" ] \
    && [ -s "$images/boot.bif" ] && dumpimage -l "$images/boot.scr" >boot-scr.txt 2>&1 \
    && grep -q 'Script' boot-scr.txt && [ "$(grep -c '^mw.l ' "$images/boot.cmd")" = 5 ]; then
    images_ok=1
    ok "image-arm.sh: $(sed -n 2p "$images/image.txt"); boot.scr: $(grep 'Image Type' boot-scr.txt | sed 's/.*: *//')"
else
    cat images.txt boot-scr.txt 2>/dev/null || true
    bad "image-arm.sh"
fi
# boot.cmd's `mw.l ADDR VALUE` lines as run-qemu.sh's `--word ADDR=VALUE`.
mapfile -t board_words < <(sed -n 's/^mw.l \(0x[0-9a-f]*\) \(0x[0-9a-f]*\)$/--word\n\1=\2/p' "$images/boot.cmd" 2>/dev/null)
board_port="$(free_port)"
"$S/run-qemu.sh" --board --serve-net "$board_port" --guest 10.0.2.16:7071 \
    ${board_words[@]+"${board_words[@]}"} "$images/fsm-firmware.bin" >board-console.txt 2>board-qemu.txt &
board_qemu=$!   # run-qemu.sh exec's QEMU: this is QEMU's PID
await_line '^SERVE NET' board-console.txt
board_up=0
[ "$images_ok" = 1 ] && grep -q '^BOARD no debugger answers' board-console.txt \
    && grep -q '^SERVE NET 10.0.2.16:7071 ' board-console.txt && board_up=1
net_dev="tcp://127.0.0.1:$board_port"
if [ "$sim_ok" = 1 ] && [ "$board_up" = 1 ] \
    && "$FSM" camera info --device "$net_dev" >board-info.txt 2>&1 \
    && grep -q '^max pixels per row *4096' board-info.txt; then
    ok "raw binary booted as by U-Boot, no debugger: console on UART1, fsm camera info over Ethernet at 10.0.2.16:7071"
else
    cat board-console.txt board-qemu.txt board-info.txt 2>/dev/null || true
    bad "raw binary booted as by U-Boot: console on UART1, fsm camera info over Ethernet"
fi
for p in paper-bfsm paper-efsm-2; do
    if [ "$sim_ok" = 1 ] && [ "$board_up" = 1 ] && link_scan "$net_dev" "$p" "board-$p" >"board-$p.rate"; then
        cat "board-$p.rate"
        ok "raw binary booted as by U-Boot: fsm camera scan, $p (32 rows x 48 pixels): candidates bit-identical"
    else
        cat "board-$p.rate" 2>/dev/null || true
        bad "raw binary booted as by U-Boot: fsm camera scan, $p"
    fi
done
kill "$board_qemu" 2>/dev/null || true
wait "$board_qemu" 2>/dev/null || true
# The same image with `--address dhcp`: QEMU's user network leases 10.0.2.15/24 to the camera.
dhcp_images="$WORK/images-dhcp"
mapfile -t dhcp_words < <("$S/image-arm.sh" --elf "$ELF" --out "$dhcp_images" --address dhcp --port 7071 >/dev/null 2>&1 \
    && sed -n 's/^mw.l \(0x[0-9a-f]*\) \(0x[0-9a-f]*\)$/--word\n\1=\2/p' "$dhcp_images/boot.cmd")
dhcp_port="$(free_port)"
"$S/run-qemu.sh" --board --serve-net "$dhcp_port" --guest 10.0.2.15:7071 \
    ${dhcp_words[@]+"${dhcp_words[@]}"} "$dhcp_images/fsm-firmware.bin" >dhcp-console.txt 2>dhcp-qemu.txt &
dhcp_qemu=$!
await_line '^SERVE NET' dhcp-console.txt
if [ "${#dhcp_words[@]}" = 10 ] && grep -q '^SERVE NET 10.0.2.15:7071 (/24 leased by DHCP' dhcp-console.txt \
    && "$FSM" camera info --device "tcp://127.0.0.1:$dhcp_port" >dhcp-info.txt 2>&1 \
    && grep -q '^max pixels per row *4096' dhcp-info.txt; then
    ok "raw binary, no debugger, --address dhcp: 10.0.2.15/24 leased from QEMU's DHCP server, fsm camera info over it"
else
    cat dhcp-console.txt dhcp-qemu.txt dhcp-info.txt 2>/dev/null || true
    bad "raw binary, no debugger, --address dhcp"
fi
kill "$dhcp_qemu" 2>/dev/null || true
wait "$dhcp_qemu" 2>/dev/null || true
set +e
"$S/run-qemu.sh" --board --timeout 30 --selftest panic "$images/fsm-firmware.bin" >board-panic.txt 2>&1
rc=$?
set -e
if [ "$rc" = 0 ] && grep -q '^PANIC: panicked at ' board-panic.txt \
    && grep -q '^RESET: stopped with code 101' board-panic.txt; then
    ok "raw binary, no debugger: a panic is reported on UART1 and resets the SoC"
else
    cat board-panic.txt
    bad "raw binary, no debugger: panic (exit $rc, want 0 from -no-reboot, PANIC and RESET lines)"
fi
# With the reset allowed to restart the image, it boots again: more than one banner in 5 s.
set +e
"$S/run-qemu.sh" --board --reboot --timeout 5 --selftest exit:7 "$images/fsm-firmware.bin" >board-reboot.txt 2>&1
set -e
boots="$(grep -c '^BOARD no debugger answers' board-reboot.txt || true)"
if [ "$boots" -ge 2 ] && grep -q '^RESET: stopped with code 7' board-reboot.txt; then
    ok "raw binary, no debugger: after a reset of the SoC the firmware boots again ($boots boots in 5 s)"
else
    head -n 20 board-reboot.txt
    bad "raw binary, no debugger: boots again after a reset ($boots boots)"
fi

# 3. Bad input: a dump of another plan, a truncated dump. Refused with a message naming what is
#    wrong, exit code 3, and no candidate file left behind.
"$TOOL" scene --plan efsm1 --width 16 --rows 4 --dump small.dump --plan-out small.plan >/dev/null
"$TOOL" scene --plan efsm2 --width 16 --rows 4 --dump other.dump --plan-out other.plan >/dev/null
head -c -100 small.dump >truncated.dump
check_refusal() { # name plan dump expected-message
    rm -f fw-candidates.bin fw-candidates.bin.part
    set +e
    "$S/run-qemu.sh" --plan "$2" "$ELF" "$3" >bad.txt 2>&1
    local rc=$?
    set -e
    if [ "$rc" = 3 ] && grep -q "^ERROR: .*$4" bad.txt && [ ! -e fw-candidates.bin ] && [ ! -e fw-candidates.bin.part ]; then
        ok "$1 refused: $(grep '^ERROR' bad.txt | cut -c1-110)"
    else
        cat bad.txt
        bad "$1: exit code $rc (want 3, an ERROR line with '$4', no output file)"
    fi
}
check_refusal "dump of another plan" other.plan small.dump "pattern_fingerprint"
check_refusal "truncated dump" small.plan truncated.dump "whole number"

# 4. Instruction counts are deterministic: two runs at shift 4 and one at shift 6 agree.
count() {
    rm -f fw-candidates.bin fw-candidates-per-pixel.bin
    ICOUNT_SHIFT="$1" "$S/run-qemu.sh" --icount --plan small.plan "$ELF" small.dump 2>/dev/null \
        | sed -n 's/^BENCH loop .* instructions=\([0-9]*\) .*/\1/p'
}
a="$(count 4)"; b="$(count 4)"; c="$(count 6)"
echo "EFSM (1 group), 4 rows x 16 pixels, loop instructions: shift4=$a shift4=$b shift6=$c"
if [ -n "$a" ] && [ "$a" = "$b" ] && [ "$a" = "$c" ] && [ "$a" -gt 100000 ]; then
    ok "instruction count deterministic: $a instructions for 64 pixels"
else
    bad "instruction counts differ or missing: '$a' '$b' '$c'"
fi

# 5. Failure paths end QEMU with the right exit code.
for t in panic:101 abort:102 undef:102 exit:7:7; do
    name="${t%:*}"
    want="${t##*:}"
    set +e
    "$S/run-qemu.sh" --timeout 30 --selftest "$name" "$ELF" >st.txt 2>&1
    rc=$?
    set -e
    if [ "$rc" = "$want" ]; then
        ok "selftest $name -> exit $rc ($(grep -E '^(PANIC|EXCEPTION)' st.txt | head -n1 | cut -c1-60))"
    else
        cat st.txt
        bad "selftest $name: exit $rc, want $want"
    fi
done

# 6. The Rust test that runs the cross-check (it skips when QEMU or a fresh ELF is missing,
#    unless FW_REQUIRE_QEMU=1; here both are present, so it must run, not skip).
#    FW_QEMU_TEST_RAN=1 (set by .ci/run, whose `FW_REQUIRE_QEMU=1 cargo test --workspace` ran
#    this test on the same ELF just before) says so instead of running its QEMU sessions again.
if [ "${FW_QEMU_TEST_RAN:-0}" = 1 ]; then
    echo "skip - cargo test --test suite qemu_crosscheck:: (FW_QEMU_TEST_RAN=1: run by the workspace tests with FW_REQUIRE_QEMU=1)"
elif FW_ELF="$BUILT_ELF" FW_REQUIRE_QEMU=1 "$HOST_CARGO" test -q --manifest-path "$FW_DIR/../Cargo.toml" --workspace \
    --test suite qemu_crosscheck:: -- --nocapture >rusttest.txt 2>&1 && ! grep -q '^SKIP' rusttest.txt; then
    grep -E '^(ok|identical)' rusttest.txt || true
    ok "cargo test -p fsm-firmware --test suite qemu_crosscheck::"
else
    cat rusttest.txt
    bad "cargo test -p fsm-firmware --test suite qemu_crosscheck::"
fi

# 7. defmt frames over semihosting, decoded on the host.
if [ "${FW_SKIP_DEFMT:-0}" = 1 ]; then
    echo "skip - defmt (FW_SKIP_DEFMT=1)"
elif ! command -v defmt-print >/dev/null; then
    echo "skip - defmt (defmt-print not installed: cargo install defmt-print)"
else
    if "$S/build-arm.sh" --defmt >build-defmt.log 2>&1; then
        DELF="$(sed -n 's/^FW_ELF=//p' build-defmt.log | tail -n1)"
        cp "$DELF" defmt.elf
        rm -f defmt.bin fw-candidates.bin
        set +e
        "$S/run-qemu.sh" --plan small.plan defmt.elf small.dump >run-defmt.txt 2>&1
        rc=$?
        set -e
        defmt-print -e defmt.elf <defmt.bin >defmt.txt 2>&1 || true
        cat defmt.txt
        if [ "$rc" = 0 ] && grep -q 'INFO  plan .* accepted' defmt.txt \
            && grep -q 'INFO  decoded 4 rows of 16 pixels' defmt.txt; then
            ok "defmt log written over semihosting and decoded by $(defmt-print --version | head -n1)"
        else
            bad "defmt log (run exit $rc)"
        fi
        # The same ELF booted as a board (no semihosting host): its defmt frames go out on
        # UART0, which QEMU writes to a file; a scan over Ethernet logs its session there.
        defmt_port="$(free_port)"
        rm -f defmt-uart0.bin
        "$S/run-qemu.sh" --board --serve-net "$defmt_port" --defmt defmt-uart0.bin defmt.elf \
            >defmt-board-console.txt 2>defmt-board-qemu.txt &
        defmt_qemu=$!
        await_line '^SERVE NET' defmt-board-console.txt
        net_dev="tcp://127.0.0.1:$defmt_port"
        defmt_scan_ok=0
        if [ "$sim_ok" = 1 ] && link_scan "$net_dev" paper-efsm-2 defmt-board >defmt-board.rate; then
            defmt_scan_ok=1
        fi
        # The session's line is logged once the host has gone: give it a moment.
        sleep 1
        kill "$defmt_qemu" 2>/dev/null || true
        wait "$defmt_qemu" 2>/dev/null || true
        defmt-print -e defmt.elf <defmt-uart0.bin >defmt-uart0.txt 2>&1 || true
        cat defmt-uart0.txt
        if [ "$defmt_scan_ok" = 1 ] \
            && grep -q 'INFO  serving the host protocol over TCP at 10.0.2.15:7070' defmt-uart0.txt \
            && grep -q 'INFO  session: [0-9]* requests, 32 rows, 0 refused' defmt-uart0.txt; then
            ok "defmt log of a board (no semihosting) written on UART0 and decoded; the scan over Ethernet bit-identical"
        else
            cat defmt-board-console.txt defmt-board-qemu.txt defmt-board.rate 2>/dev/null || true
            bad "defmt log on UART0 of a board"
        fi
    else
        cat build-defmt.log
        bad "build-arm.sh --defmt"
    fi
    # The default ELF again, for anything that runs after this script.
    "$S/build-arm.sh" >/dev/null 2>&1 || bad "build-arm.sh (rebuild without defmt)"
fi

echo "$pass passed, $fail failed"
[ "$fail" = 0 ]
