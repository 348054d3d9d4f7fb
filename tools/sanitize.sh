#!/usr/bin/env bash
# Runs the pytest suite against a build of the native module with AddressSanitizer and
# UndefinedBehaviorSanitizer (IDEALIZE_SANITIZE=ON, g++), leaving the normal module alone.
#
#   bash tools/sanitize.sh [PYTEST ARGS ...]      # e.g. -k mesh_io, or -x
#
# The module is built in build-asan/ and written to build-asan/module/ (IDEALIZE_MODULE_DIR), never
# to idealize/. build-asan/tree/ mirrors the repository with symbolic links, except that its
# idealize/ package links the sanitized module; pytest runs from there (the tests put their own
# repository root first on sys.path, so PYTHONPATH alone would not do). /usr/bin/python3 is not
# built with ASan, so its runtime is preloaded (LD_PRELOAD=$(g++ -print-file-name=libasan.so), with
# libstdc++ after it) and
# leak detection is off (CPython keeps its objects until exit by design). Undefined behaviour halts.
# tests/test_gui.py is left out: FreeCAD loads the workbench from the real repository (the normal
# module) through its Mod link, so it would not test this build; set SANITIZE_GUI=1 to run it anyway.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD=build-asan

mkdir -p "$BUILD"
LOG="$BUILD/build.log"
CXX=g++ cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DIDEALIZE_SANITIZE=ON \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g" -DIDEALIZE_MODULE_DIR="$ROOT/$BUILD/module" \
  > "$LOG" 2>&1 || { cat "$LOG"; exit 1; }
cmake --build "$BUILD" -j"$(nproc)" --target _native >> "$LOG" 2>&1 || { tail -50 "$LOG"; exit 1; }
MODULE=$(ls "$BUILD"/module/_native*.so)

# The mirror: links to everything at the top of the repository but the build folders and idealize/.
TREE="$ROOT/$BUILD/tree"
rm -rf "$TREE"
mkdir -p "$TREE/idealize"
for entry in "$ROOT"/* "$ROOT"/.ci; do
  name=$(basename "$entry")
  [ -e "$entry" ] || continue
  case "$name" in idealize|build|build-*) continue ;; esac
  ln -s "$entry" "$TREE/$name"
done
for entry in "$ROOT"/idealize/*; do
  name=$(basename "$entry")
  case "$name" in _native*.so|__pycache__) continue ;; esac
  ln -s "$entry" "$TREE/idealize/$name"
done
ln -s "$ROOT/$MODULE" "$TREE/idealize/$(basename "$MODULE")"

# libstdc++ is preloaded too: Python does not link it, and ASan's __cxa_throw interceptor must find it
# at start-up (otherwise the first C++ exception ends in "CHECK failed ... real___cxa_throw").
export LD_PRELOAD="$(g++ -print-file-name=libasan.so) $(g++ -print-file-name=libstdc++.so)"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export PYTHONDONTWRITEBYTECODE=1
cd "$TREE"
/usr/bin/python3 -c "import sys; sys.path.insert(0, '.'); import idealize._native as n; \
assert n.__file__.startswith('$TREE/'), n.__file__; print('sanitized module:', n.__file__)"
IGNORE=(--ignore=tests/test_gui.py)
[ "${SANITIZE_GUI:-0}" = 1 ] && IGNORE=()
exec /usr/bin/python3 -m pytest -q -p no:cacheprovider "${IGNORE[@]}" tests "$@"
