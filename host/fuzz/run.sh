#!/usr/bin/env bash
# Runs every fuzz target of the host's file parsers for the given number of seconds each
# (default 20), starting from the checked-in seeds (seeds/<target>/: the repository's own
# calibration, target, plan, response, image, dump and candidate files); new inputs go to
# corpus/<target>/ (not checked in). The runner is core/fuzz/run.sh (toolchain, FUZZ_SEED,
# failure rules), given this folder.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
exec bash "$here/../../core/fuzz/run.sh" "${1:-20}" "$here"
