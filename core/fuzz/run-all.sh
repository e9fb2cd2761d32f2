#!/usr/bin/env bash
# Longer fuzzing on demand: every target of fsm-core (core/fuzz) and of the host's file parsers
# (host/fuzz) for MINUTES each (default 10), with libFuzzer's own random seed unless FUZZ_SEED
# is set, keeping what each run adds to corpus/<target>/. Ends with one line per target (runs,
# corpus size, crashes) per crate; fails like run.sh (a crash, a target that ran no input, a
# crate without targets). 15 targets (core's 4, the host's 11), two at a time (FUZZ_JOBS):
# 10 minutes each is about 1 h 20 min with the two crates' builds.
# Usage: core/fuzz/run-all.sh [minutes]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
minutes=${1:-10}
export FUZZ_SEED=${FUZZ_SEED:-0}
seconds=$((minutes * 60))
bash "$here/run.sh" "$seconds" "$here"
bash "$here/run.sh" "$seconds" "$here/../../host/fuzz"
