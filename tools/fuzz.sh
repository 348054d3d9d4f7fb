#!/usr/bin/env bash
# Builds the libFuzzer targets of native/fuzz/ with clang into build-fuzz/ and runs each for N seconds.
#
#   bash tools/fuzz.sh [SECONDS] [TARGET ...]     # default 60 s, every target
#   FUZZ_JOBS=2 bash tools/fuzz.sh 120            # run two targets at a time
#
# Each target starts from a copy of its seed corpus native/fuzz/corpus/<target>/ in
# build-fuzz/corpus/<target>/ (the seeds in the repository are not touched); crashes land in
# build-fuzz/artifacts/<target>/ and the log in build-fuzz/logs/<target>.log. A summary line per
# target gives executions/s and the corpus size at the end. Exit status 1 if any target crashed; an
# input that only times out is reported but does not fail the run (FUZZ_STRICT_TIMEOUTS=1: it does).
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET=${1:-60}
shift || true
ALL_TARGETS=(fuzz_stl_binary fuzz_stl_ascii fuzz_obj fuzz_off fuzz_ply fuzz_segment fuzz_sculpt fuzz_edit)
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=("${ALL_TARGETS[@]}")
JOBS=${FUZZ_JOBS:-1}
BUILD=build-fuzz

# RelWithDebInfo without -DNDEBUG: Eigen's bounds assertions stay on.
mkdir -p "$BUILD"
LOG="$BUILD/build.log"
CXX=${CXX:-clang++} cmake -S . -B "$BUILD" -DIDEALIZE_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g" > "$LOG" 2>&1 || { cat "$LOG"; exit 1; }
cmake --build "$BUILD" -j"$(nproc)" --target "${TARGETS[@]}" >> "$LOG" 2>&1 || { tail -50 "$LOG"; exit 1; }

run_target() {
  local target=$1 corpus="$BUILD/corpus/$1" artifacts="$BUILD/artifacts/$1/" log="$BUILD/logs/$1.log"
  local max_len=4096 timeout=10
  if [ "$target" = fuzz_segment ]; then max_len=1024; timeout=30; fi
  if [ "$target" = fuzz_sculpt ]; then max_len=1024; timeout=30; fi
  # An edit remeshes a part under the sanitizers (seconds); the first of each part makes its layer.
  if [ "$target" = fuzz_edit ]; then max_len=64; timeout=120; fi
  mkdir -p "$corpus" "$artifacts" "$BUILD/logs"
  cp -n native/fuzz/corpus/"$target"/* "$corpus"/ 2>/dev/null || true
  local status=0
  "$BUILD/$target" "$corpus" -max_total_time="$SECONDS_PER_TARGET" -max_len="$max_len" \
    -timeout="$timeout" -print_final_stats=1 -artifact_prefix="$artifacts" > "$log" 2>&1 || status=$?
  local execs time rate files bytes
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  time=$(sed -n 's/.*Done [0-9]* runs in \([0-9]*\) second.*/\1/p' "$log" | tail -1)
  rate=$(sed -n 's/.* exec\/s: \([0-9]*\).*/\1/p' "$log" | tail -1)
  files=$(find "$corpus" -type f | wc -l)
  bytes=$(du -sb "$corpus" | cut -f1)
  if [ "$status" -ne 0 ] && [ -z "$execs" ]; then
    printf '%-16s FAILED to run (status %s); see %s\n' "$target" "$status" "$log"
  elif [ "$status" -eq 70 ]; then
    # libFuzzer's timeout exit code: an input ran longer than the timeout. Slow, not a crash (inputs
    # that were slow live in native/fuzz/known-slow/); FUZZ_STRICT_TIMEOUTS=1 counts it as a failure.
    printf '%-16s TIMEOUT after %s executions: a slow input (> %s s) in %s\n' "$target" "${execs:-?}" \
      "$timeout" "$artifacts"
    [ "${FUZZ_STRICT_TIMEOUTS:-0}" = 1 ] || status=0
  elif [ "$status" -ne 0 ]; then
    printf '%-16s CRASH (status %s) after %s executions; see %s and %s\n' "$target" "$status" \
      "${execs:-?}" "$log" "$artifacts"
  else
    printf '%-16s %s s, %s executions, %s exec/s, corpus %s files (%s bytes)\n' "$target" \
      "${time:-?}" "${execs:-?}" "${rate:-?}" "$files" "$bytes"
  fi
  return "$status"
}

failed=0
pids=()
for target in "${TARGETS[@]}"; do
  run_target "$target" & pids+=($!)
  if [ ${#pids[@]} -ge "$JOBS" ]; then
    wait "${pids[0]}" || failed=1
    pids=("${pids[@]:1}")
  fi
done
for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
exit "$failed"
