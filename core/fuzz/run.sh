#!/usr/bin/env bash
# Runs every fuzz target of fsm-core for the given number of seconds each (default 20).
# Uses the nightly toolchain when present, otherwise the stable one with RUSTC_BOOTSTRAP (the
# fuzzing flags are unstable), and installs cargo-fuzz if it is missing. The seed is fixed (FUZZ_SEED,
# default 1) so a CI run can be replayed; set it to 0 for libFuzzer's own random seed.
set -euo pipefail
cd "$(dirname "$0")"
seconds=${1:-20}
command -v cargo-fuzz >/dev/null || cargo install --locked cargo-fuzz@0.13.2
if rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
    fuzz=(cargo +nightly fuzz)
else
    export RUSTC_BOOTSTRAP=1
    fuzz=(cargo fuzz)
fi
# Built first, so that a target that does not compile fails here rather than in a filtered log.
"${fuzz[@]}" build
for target in $("${fuzz[@]}" list); do
    echo "== fuzz $target for ${seconds}s"
    status=0
    "${fuzz[@]}" run "$target" -- -seed="${FUZZ_SEED:-1}" -max_total_time="$seconds" 2>&1 |
        { grep -E '^Done|panicked|ERROR|SUMMARY' || true; } || status=$?
    if [ -n "$(ls -A "artifacts/$target" 2>/dev/null)" ]; then
        echo "fuzz $target found a crash: core/fuzz/artifacts/$target" >&2
        exit 1
    fi
    if [ "$status" -ne 0 ]; then
        echo "fuzz $target failed (exit status $status)" >&2
        exit 1
    fi
done
