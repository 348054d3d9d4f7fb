#!/usr/bin/env bash
# Runs every test of Idealize (builds first, installing what is missing when run as root): the C++
# unit tests (ctest), the pytest suite, then a bounded fuzzing run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh --no-sample
ctest --test-dir build --output-on-failure
/usr/bin/python3 -m pytest -q tests "$@"
# A bounded run of every libFuzzer target (mesh readers, segmentation); a crash fails the tests.
# IDEALIZE_FUZZ_SECONDS=0 skips it; tools/fuzz.sh runs longer campaigns.
FUZZ_SECONDS=${IDEALIZE_FUZZ_SECONDS:-30}
if [ "$FUZZ_SECONDS" -gt 0 ]; then
  bash tools/fuzz.sh "$FUZZ_SECONDS"
fi
