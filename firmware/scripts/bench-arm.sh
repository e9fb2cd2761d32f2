#!/usr/bin/env bash
# Firmware benchmark: exact instructions per pixel on the emulated Cortex-A9 (QEMU -icount,
# see src/icount.rs) for the paper's BFSM plan and its EFSM plans (cB 64, one and two groups),
# on the mirror scene (interreflections on a third of every row, a shadow at its end).
#
# Usage: scripts/bench-arm.sh [--rows N] [--width W]     (default 8 rows of 48 pixels)
# Plans: the paper's three with the CLEAN search, then the same with the local-maximum search
# (-fast, `DecodeSettings::local_maxima`); FW_BENCH_PLANS="efsm1 efsm1-fast" picks some.
# Environment: FW_ELF (default: build with scripts/build-arm.sh), ICOUNT_SHIFT (default 4).
#
# For each plan it prints the firmware's BENCH lines:
#   BENCH tables ...    building the plan's decoder tables (once per plan)
#   BENCH loop ...      whole loop per pixel: unpack the record, decode_row, encode, write
#   BENCH decode ...    the loop's decode_row_lanes alone (4 pixels per NEON register)
#   BENCH pixels ...    decode only, pixel by pixel (one lane), by the number of candidates found
# and checks that both passes wrote the candidates the host computes (bit-identical).
set -euo pipefail

FW_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
S="$FW_DIR/scripts"
ROWS=8
WIDTH=48
while [ $# -gt 0 ]; do
    case "$1" in
        --rows) ROWS="$2"; shift ;;
        --width) WIDTH="$2"; shift ;;
        *) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2 ;;
    esac
    shift
done

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

HOST_CARGO="$(command -v cargo)"
case "$HOST_CARGO" in /usr/bin/cargo) [ -x "$HOME/.cargo/bin/cargo" ] && HOST_CARGO="$HOME/.cargo/bin/cargo" ;; esac
"$HOST_CARGO" build -q --release --manifest-path "$FW_DIR/Cargo.toml" -p fsm-firmware --bin fsm-firmware
TARGET_DIR="$("$HOST_CARGO" metadata --format-version 1 --no-deps --manifest-path "$FW_DIR/Cargo.toml" \
    | python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')"
TOOL="$TARGET_DIR/release/fsm-firmware"

if [ -z "${FW_ELF:-}" ]; then
    "$S/build-arm.sh" >"$WORK/build.log" 2>&1 || { cat "$WORK/build.log"; exit 1; }
    FW_ELF="$(sed -n 's/^FW_ELF=//p' "$WORK/build.log" | tail -n1)"
fi
cp "$FW_ELF" "$WORK/fsm-firmware.elf"
cd "$WORK"

status=0
echo "firmware benchmark: $ROWS rows x $WIDTH pixels per plan, QEMU -icount shift=${ICOUNT_SHIFT:-4} (exact)"
for p in ${FW_BENCH_PLANS:-bfsm efsm1 efsm2 bfsm-fast efsm1-fast efsm2-fast}; do
    "$TOOL" scene --plan "$p" --width "$WIDTH" --rows "$ROWS" --dump "$p.dump" --plan-out "$p.plan" >/dev/null
    "$TOOL" decode --plan "$p.plan" --dump "$p.dump" --out "$p.host.cand" >/dev/null
    rm -f fw-candidates.bin fw-candidates-per-pixel.bin
    echo
    echo "== $p"
    QEMU_TIMEOUT="${QEMU_TIMEOUT:-600}" "$S/run-qemu.sh" --icount --plan "$p.plan" fsm-firmware.elf "$p.dump" 2>&1 \
        | grep -E '^(PLAN|BENCH|ERROR|PANIC)|run-qemu: exit'
    for out in fw-candidates.bin fw-candidates-per-pixel.bin; do
        if ! "$TOOL" compare "$p.host.cand" "$out" >/dev/null; then
            echo "FAIL: $p: $out differs from the host's decode"
            status=1
        fi
    done
done
exit "$status"
