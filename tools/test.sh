#!/usr/bin/env bash
# Runs every test of Idealize (builds first, installing what is missing when run as root): the C++
# unit tests (ctest), the pytest suite, then a bounded fuzzing run. This is the CI command.
#
#   bash tools/test.sh           # everything (about 25 minutes)
#   bash tools/test.sh --fast    # the fast loop (a few minutes): ctest, the unit tests of the
#                                # readers, bad input, curvature, progress and the benchmark's
#                                # scores, the fuzzing regressions, and the command line's
#                                # end-to-end conversions; no GUI, no ../shared/data, no fuzzing
# Further arguments go to pytest (for example -k NAME).
set -euo pipefail
cd "$(dirname "$0")/.."
FAST=0
if [ "${1:-}" = "--fast" ]; then
  FAST=1
  shift
fi
bash tools/setup.sh --no-sample
ctest --test-dir build --output-on-failure
if [ "$FAST" = 1 ]; then
  exec /usr/bin/python3 -m pytest -q tests/test_mesh_io.py tests/test_bad_input.py tests/test_curvature.py \
    tests/test_progress.py tests/test_bench_scoring.py tests/test_fuzz_regressions.py tests/test_cli.py \
    -k "not slow_input" "$@"
fi
/usr/bin/python3 -m pytest -q tests "$@"
# A bounded run of every libFuzzer target (mesh readers, segmentation); a crash fails the tests.
# IDEALIZE_FUZZ_SECONDS=0 skips it; tools/fuzz.sh runs longer campaigns.
FUZZ_SECONDS=${IDEALIZE_FUZZ_SECONDS:-30}
if [ "$FUZZ_SECONDS" -gt 0 ]; then
  bash tools/fuzz.sh "$FUZZ_SECONDS"
fi
