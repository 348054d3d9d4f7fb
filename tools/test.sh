#!/usr/bin/env bash
# Runs every test of Idealize (builds first, installing what is missing when run as root).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh --no-sample
exec /usr/bin/python3 -m pytest -q tests "$@"
