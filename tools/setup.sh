#!/usr/bin/env bash
# Idealize set-up on Debian 12, as root: installs what is missing, builds the native core for
# /usr/bin/python3 (FreeCAD's interpreter), links the workbench into FreeCAD's Mod folder and, unless
# --no-sample is given, runs the main job on the bundled sample mesh.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

PACKAGES=(freecad cmake g++ make pybind11-dev python3-pybind11 python3-dev python3-numpy python3-scipy
          python3-skimage python3-matplotlib python3-pytest libeigen3-dev libcgal-dev libgmp-dev libmpfr-dev
          libocct-foundation-dev libocct-modeling-data-dev libocct-modeling-algorithms-dev
          libocct-data-exchange-dev libocct-ocaf-dev xvfb xauth clang libclang-rt-14-dev)

missing=()
for package in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  if [ "$(id -u)" -ne 0 ]; then echo "error: run as root (apt-get install needed)" >&2; exit 1; fi
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

cmake -S . -B build -DCMAKE_BUILD_TYPE=Release > build.log 2>&1 || { cat build.log; exit 1; }
cmake --build build -j"$(nproc)" >> build.log 2>&1 || { tail -50 build.log; exit 1; }
/usr/bin/python3 -c "import idealize" || { echo "error: idealize does not import" >&2; exit 1; }

# FreeCAD finds workbenches in its user Mod folder: link the repository there.
MOD_DIR="${HOME}/.local/share/FreeCAD/Mod"
mkdir -p "$MOD_DIR"
if [ -L "$MOD_DIR/Idealize" ] || [ ! -e "$MOD_DIR/Idealize" ]; then
  ln -sfn "$ROOT" "$MOD_DIR/Idealize"
else
  echo "note: $MOD_DIR/Idealize exists and is not a link; left as it is" >&2
fi

if [ "${1:-}" != "--no-sample" ]; then
  /usr/bin/python3 -m idealize convert samples/bracket.stl -o sample-output.step --report sample-report.json
fi
