#!/usr/bin/env bash
# Runs every fuzz target (this folder's cargo-fuzz crate: the core's wire formats and decoder,
# the host's file parsers) for the given number of seconds each (default 20). New inputs go to
# corpus/<target>/; checked-in seeds/<target>/ start the run where the target has them. Uses
# the nightly toolchain when present, otherwise the stable one with RUSTC_BOOTSTRAP (the fuzzing
# flags are unstable), and installs cargo-fuzz if it is missing. The seed is fixed (FUZZ_SEED,
# default 1) so a CI run can be replayed; set it to 0 for libFuzzer's own random seed. Fails on
# the first target that does not build, exits non-zero, leaves a crash in artifacts/ or ran no
# input, and when the crate lists no target at all: a fuzz step that fuzzed nothing is a
# failure, not a pass. Runs FUZZ_JOBS targets at a time (default: one per core). Ends with one
# line per target: runs, corpus size, crashes.
# Usage: tests/fuzz/run.sh [seconds]
set -euo pipefail
seconds=${1:-20}
# libFuzzer takes -max_total_time=0 as "no limit".
[[ "$seconds" =~ ^[1-9][0-9]*$ ]] || { echo "fuzz: seconds must be a positive integer, not '$seconds'" >&2; exit 2; }
cd "$(dirname "$0")"
where=$(basename "$(dirname "$PWD")")/$(basename "$PWD")
command -v cargo-fuzz >/dev/null || cargo install --locked cargo-fuzz@0.13.2
if rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
    fuzz=(cargo +nightly fuzz)
else
    export RUSTC_BOOTSTRAP=1
    fuzz=(cargo fuzz)
fi
# Every command names the fuzz crate's folder rather than rely on cargo-fuzz's search (`fuzz/`
# beside the nearest parent manifest).
dir=(--fuzz-dir "$PWD")
# Built first, so that a target that does not compile fails here rather than in a filtered log.
"${fuzz[@]}" build "${dir[@]}"
targets=$("${fuzz[@]}" list "${dir[@]}")
if [ -z "$targets" ]; then
    echo "fuzz: $where lists no fuzz target" >&2
    exit 1
fi
# Two targets at a time by default (FUZZ_JOBS): libFuzzer runs one process per target, so on the
# 2-core machine this halves the wall time and not one target's seconds.
jobs=${FUZZ_JOBS:-$(nproc 2>/dev/null || echo 1)}
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || { echo "fuzz: FUZZ_JOBS must be a positive integer, not '$jobs'" >&2; exit 2; }
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
# fuzz_one TARGET: runs it, its output in $logs/TARGET.log, its exit status in $logs/TARGET.status.
fuzz_one() {
    local target=$1 status=0
    mkdir -p "corpus/$target"
    local inputs=("corpus/$target")
    [ -d "seeds/$target" ] && inputs+=("seeds/$target")
    "${fuzz[@]}" run "${dir[@]}" "$target" "${inputs[@]}" -- \
        -seed="${FUZZ_SEED:-1}" -max_total_time="$seconds" >"$logs/$target.log" 2>&1 || status=$?
    echo "$status" >"$logs/$target.status"
}
running=0
for target in $targets; do
    if [ "$running" -ge "$jobs" ]; then
        wait -n || true
        running=$((running - 1))
    fi
    echo "== fuzz $target for ${seconds}s"
    fuzz_one "$target" &
    running=$((running + 1))
done
wait
# Judged in the listed order, so that the first failing target is reported the same way each run;
# every target's line is printed before the verdict, so that a long run that found a crash in one
# target still records what the others did.
summary=()
failed=""
for target in $targets; do
    log="$logs/$target.log"
    status=$(cat "$logs/$target.status" 2>/dev/null || echo "none")
    echo "== $target"
    grep -E '^Done|panicked|ERROR|SUMMARY' "$log" || true
    # libFuzzer ends with `Done N runs in S second(s)`: no such line, or N = 0, fuzzed nothing.
    runs=$(sed -n 's/^Done \([0-9]*\) runs in .*/\1/p' "$log" | tail -n1)
    corpus=$(ls "corpus/$target" | wc -l)
    if [ -n "$(ls -A "artifacts/$target" 2>/dev/null)" ]; then
        summary+=("$target: CRASH, input in $where/artifacts/$target (corpus $corpus inputs)")
        failed=${failed:-"fuzz $target found a crash: $where/artifacts/$target"}
    elif [ "$status" != 0 ]; then
        tail -n 20 "$log" >&2
        summary+=("$target: FAILED, exit status $status")
        failed=${failed:-"fuzz $target failed (exit status $status)"}
    elif [ -z "$runs" ] || [ "$runs" -eq 0 ]; then
        tail -n 20 "$log" >&2
        summary+=("$target: ran no input")
        failed=${failed:-"fuzz $target ran no input"}
    else
        summary+=("$target: $runs runs in ${seconds} s, corpus $corpus inputs, 0 crashes")
    fi
done
echo "== fuzz $where: ${#summary[@]} targets, $jobs at a time"
printf '  %s\n' "${summary[@]}"
if [ -n "$failed" ]; then
    echo "$failed" >&2
    exit 1
fi
