#!/usr/bin/env bash
# Longer fuzzing on demand: every target (the core's 4, the host's 11) for MINUTES each
# (default 10), with libFuzzer's own random seed unless FUZZ_SEED is set, keeping what each run
# adds to corpus/<target>/. Ends with one line per target (runs, corpus size, crashes); fails
# like run.sh (a crash, a target that ran no input). Two targets at a time (FUZZ_JOBS):
# 10 minutes each is about 1 h 20 min with the build.
# Usage: tests/fuzz/run-all.sh [minutes]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
minutes=${1:-10}
export FUZZ_SEED=${FUZZ_SEED:-0}
bash "$here/run.sh" "$((minutes * 60))"
