#!/usr/bin/env bash
# The firmware cross-check: the candidate rows the Cortex-A9 firmware computes under QEMU must be
# bit-identical to the host's decode of the same row dump (fsm-core on x86_64), whole files
# (header + records) compared byte for byte, for a BFSM plan, a two-group EFSM plan and the four
# baselines the paper compares them with (phase shift, Micro Phase Shifting, Code Ensemble, line
# scanning, on a 128-column projector), on a scene with interreflections, whose truth the host's
# decode must match (`fsm-firmware truth`; a baseline, which sees one light per pixel, where the
# mirror does not light the pixel, within 1 column). Identical files must hold every row (an
# external dump: at least one) and a lit pixel. Twice per plan:
#   1. replay: the row dump placed in RAM, the plan in its mailbox -> fw-candidates.bin;
#   2. protocol: a recorded host session placed in RAM (plan upload, scan, every row, with one
#      of each kind of bad input first) served by the device loop -> fw-link.bin, whose
#      answers must be the expected ones (an error for each bad input) and whose candidate
#      rows must again equal the host's.
#
# Usage: scripts/crosscheck-arm.sh [--rows N] [--baseline-rows N] [--width W] [--methods LIST] [--keep DIR]
#   --rows N    rows per dump (default 32)
#   --baseline-rows N   rows per dump of a baseline (default 16)
#   --width W   pixels per row (default 48; QEMU needs ~2 s per 1500 BFSM pixels)
#   --methods LIST   plans to check (default "bfsm efsm2 ps mps ce ls")
#   --keep DIR  keep dumps, plans and candidate files in DIR (default: a temporary directory)
# Environment:
#   FW_ELF             firmware ELF to run (default: build it with scripts/build-arm.sh)
#   FW_DUMP_<P>, FW_PLAN_<P>   for P in BFSM, EFSM2, PS, MPS, CE, LS: use this row dump and plan
#                      file (its wire bytes, `fsm plan --wire`) instead of rendering the built-in
#                      mirror scene (e.g. the simulator's plane_mirror dump)
#   QEMU_TIMEOUT       seconds per QEMU run (default 300)
# Prints one line per check and ends with `N passed, M failed`; exit status 0 iff all passed.
set -euo pipefail

FW_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
S="$FW_DIR/scripts"
ROWS=32
BASELINE_ROWS=16
WIDTH=48
METHODS="bfsm efsm2 ps mps ce ls"
KEEP=""
while [ $# -gt 0 ]; do
    case "$1" in
        --rows) ROWS="$2"; shift ;;
        --baseline-rows) BASELINE_ROWS="$2"; shift ;;
        --width) WIDTH="$2"; shift ;;
        --methods) METHODS="$2"; shift ;;
        --keep) KEEP="$2"; shift ;;
        *) sed -n '2,28p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2 ;;
    esac
    shift
done

pass=0
fail=0
ok() { pass=$((pass + 1)); echo "ok   - $*"; }
bad() { fail=$((fail + 1)); echo "FAIL - $*"; }

if [ -n "$KEEP" ]; then
    mkdir -p "$KEEP"
    WORK="$(cd "$KEEP" && pwd)"
else
    WORK="$(mktemp -d)"
    trap 'rm -rf "$WORK"' EXIT
fi

# The host tools (scene, decode, compare): rustup's cargo, the workspace's own target dir, its
# one profile (dev) and the features `cargo test --workspace` resolves (its build links the
# binaries too), so after that command nothing is rebuilt.
HOST_CARGO="$(command -v cargo)"
case "$HOST_CARGO" in /usr/bin/cargo) [ -x "$HOME/.cargo/bin/cargo" ] && HOST_CARGO="$HOME/.cargo/bin/cargo" ;; esac
"$HOST_CARGO" test -q --manifest-path "$FW_DIR/../Cargo.toml" --workspace --no-run
TARGET_DIR="$("$HOST_CARGO" metadata --format-version 1 --no-deps --manifest-path "$FW_DIR/Cargo.toml" \
    | python3 -c 'import json, sys; print(json.load(sys.stdin)["target_directory"])')"
TOOL="$TARGET_DIR/debug/fsm-firmware"

if [ -z "${FW_ELF:-}" ]; then
    "$S/build-arm.sh" >"$WORK/build.log" 2>&1 || { cat "$WORK/build.log"; bad "build-arm.sh"; echo "$pass passed, $fail failed"; exit 1; }
    grep -A1 '^ *text' "$WORK/build.log"
    FW_ELF="$(sed -n 's/^FW_ELF=//p' "$WORK/build.log" | tail -n1)"
fi
cp "$FW_ELF" "$WORK/fsm-firmware.elf"
ELF="$WORK/fsm-firmware.elf"

cd "$WORK"
for p in $METHODS; do
    P="$(echo "$p" | tr 'a-z' 'A-Z')"
    dump_var="FW_DUMP_$P"
    plan_var="FW_PLAN_$P"
    # The baselines see one light per pixel; Code Ensemble's columns are whole codewords.
    case "$p" in
        bfsm|efsm1|efsm2) rows=$ROWS; tolerance=0.5 ;;
        ps|mps|ce|ls) rows=$BASELINE_ROWS; tolerance=1 ;;
        *) echo "crosscheck-arm: unknown method $p (bfsm efsm1 efsm2 ps mps ce ls)" >&2; exit 2 ;;
    esac
    if [ -n "${!dump_var:-}" ]; then
        cp "${!dump_var}" "$p.dump"
        cp "${!plan_var:?$plan_var must name the plan file (wire bytes) of the dump}" "$p.plan"
        echo "$p: dump ${!dump_var}"
    else
        "$TOOL" scene --plan "$p" --width "$WIDTH" --rows "$rows" --dump "$p.dump" --plan-out "$p.plan"
    fi
    "$TOOL" decode --plan "$p.plan" --dump "$p.dump" --out "$p.host.cand"
    # The host's decode is held to the scene's truth: the firmware is compared with the host,
    # and both share the same core, so a decoder bug would otherwise pass.
    if [ -n "${!dump_var:-}" ]; then
        echo "$p: external dump, no truth to compare with"
        min_rows=1
    elif "$TOOL" truth --plan "$p.plan" --width "$WIDTH" --rows "$rows" --candidates "$p.host.cand" \
        --tolerance "$tolerance"; then
        ok "$p: the host's decode matches the scene's truth"
        min_rows=$rows
    else
        bad "$p: the host's decode does not match the scene's truth"
        min_rows=$rows
    fi
    rm -f fw-candidates.bin
    set +e
    QEMU_TIMEOUT="${QEMU_TIMEOUT:-300}" "$S/run-qemu.sh" --plan "$p.plan" "$ELF" "$p.dump" >"$p.qemu.txt" 2>&1
    rc=$?
    set -e
    cat "$p.qemu.txt"
    if [ "$rc" != 0 ] || [ ! -f fw-candidates.bin ]; then
        bad "$p: firmware exit code $rc, no candidate file"
        continue
    fi
    mv fw-candidates.bin "$p.fw.cand"
    if "$TOOL" compare "$p.host.cand" "$p.fw.cand" --min-rows "$min_rows"; then
        ok "$p: firmware (Cortex-A9, QEMU) and host (x86_64) candidates bit-identical ($(stat -c %s "$p.fw.cand") bytes)"
    else
        bad "$p: firmware and host candidates differ"
    fi

    "$TOOL" session --plan "$p.plan" --dump "$p.dump" --out "$p.requests" --bad-input yes
    rm -f fw-link.bin
    set +e
    QEMU_TIMEOUT="${QEMU_TIMEOUT:-300}" "$S/run-qemu.sh" "$ELF" "$p.requests" >"$p.session.txt" 2>&1
    rc=$?
    set -e
    cat "$p.session.txt"
    if [ "$rc" = 0 ] && [ -f fw-link.bin ] \
        && "$TOOL" replies --plan "$p.plan" --dump "$p.dump" --in fw-link.bin --out "$p.link.cand" --bad-input yes \
        && "$TOOL" compare "$p.host.cand" "$p.link.cand" --min-rows "$min_rows"; then
        ok "$p: protocol session on the Cortex-A9: 6 bad inputs refused with errors, then candidates bit-identical"
    else
        bad "$p: protocol session (firmware exit code $rc)"
    fi
done

echo "$pass passed, $fail failed"
[ "$fail" = 0 ]
