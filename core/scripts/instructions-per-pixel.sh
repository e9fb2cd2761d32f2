#!/usr/bin/env bash
# Instructions the line decoder executes per pixel on this machine (x86_64), counted by
# callgrind: the difference between 6 and 2 decodes of a 256-pixel row, so set-up cancels.
# Usage: core/scripts/instructions-per-pixel.sh [bfsm] [efsm1] [efsm2] [efsm1-shadow] ...
# (a plan name with -fast: the local-maximum search; with -shadow: every pixel in shadow; e.g.
# efsm1-fast-shadow; see core/examples/decode_loop.rs)
set -euo pipefail
cd "$(dirname "$0")/../.."
command -v valgrind >/dev/null || { echo "valgrind is needed (apt-get install valgrind)" >&2; exit 1; }
cargo build -q --release -p fsm-core --example decode_loop
bin=${CARGO_TARGET_DIR:-target}/release/examples/decode_loop
count() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$bin" "$1" "$2" 2>&1 |
        awk '/Collected/ { print $4 }'
}
for plan in "${@:-bfsm efsm1 efsm2}"; do
    for p in $plan; do
        a=$(count "$p" 2)
        b=$(count "$p" 6)
        echo "$p: $(( (b - a) / (4 * 256) )) instructions per pixel"
    done
done
