#!/bin/bash
# Runs every fuzz target of fuzz/ for SECONDS each (default 60), two at a time, from its seed corpus
# fuzz/corpus/<target>/ (read only: what a run adds goes to a scratch copy), with leak detection,
# a time limit per input for hangs and libFuzzer's memory limit. Prints each target's executions and
# fails when any target finds a crash, a hang, a leak, a sanitizer report or runs out of memory;
# the input that did it is kept as BUILD/fuzz-runs/<target>/crash-* (or leak-, timeout-, oom-).
#
# Usage: scripts/run-fuzzers.sh [SECONDS] [BUILD]   (BUILD: build/fuzz, made by the preset `fuzz`:
#   cmake --preset fuzz && cmake --build --preset fuzz)
# Replay a finding: BUILD/fuzz/fuzz_TARGET FILE
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
build=${2:-build/fuzz}
targets=(pfm ply calibration scene image params)
out="$build/fuzz-runs"
rm -rf "$out"
mkdir -p "$out"

# Leaks are checked after every input (libFuzzer's -detect_leaks, on by default with ASan); UBSan
# stops at the first report. OpenCV reads OPENCV_IO_MAX_IMAGE_PIXELS when its library loads: images
# within the program's 32768 x 32768 could need gigabytes, beyond libFuzzer's -rss_limit_mb.
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
export OPENCV_IO_MAX_IMAGE_PIXELS=4194304
export OMP_WAIT_POLICY=passive

run_one() {
  local t=$1 bin="$build/fuzz/fuzz_$1" dir="$out/$1"
  mkdir -p "$dir/corpus"
  if [ ! -x "$bin" ]; then
    echo "fuzz_$t: $bin is missing (cmake --preset fuzz && cmake --build --preset fuzz)" > "$dir/log"
    echo 1 > "$dir/status"
    return
  fi
  local status=0
  "$bin" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=2048 -malloc_limit_mb=2048 -detect_leaks=1 \
    -print_final_stats=1 -artifact_prefix="$dir/" "$dir/corpus" "fuzz/corpus/$t" > "$dir/log" 2>&1 || status=$?
  echo "$status" > "$dir/status"
}

# Two at a time.
running=0
for t in "${targets[@]}"; do
  run_one "$t" &
  running=$((running + 1))
  if [ "$running" -ge 2 ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait

failed=0
printf '%-12s %12s %8s %s\n' target executions corpus result
for t in "${targets[@]}"; do
  dir="$out/$t"
  status=$(cat "$dir/status" 2>/dev/null || echo 1)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log" | tail -1)
  units=$(find "$dir/corpus" -type f | wc -l)
  findings=$(find "$dir" -maxdepth 1 -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' \
    -o -name 'oom-*' -o -name 'slow-unit-*' \) | wc -l)
  result=ok
  if [ "$status" != 0 ] || [ "$findings" != 0 ] || [ -z "$execs" ]; then
    result="FAILED (exit $status, $findings finding(s)): see $dir/log"
    failed=1
  fi
  printf '%-12s %12s %8s %s\n' "fuzz_$t" "${execs:-?}" "+$units" "$result"
done
if [ "$failed" != 0 ]; then
  for t in "${targets[@]}"; do
    if [ "$(cat "$out/$t/status" 2>/dev/null || echo 1)" != 0 ]; then
      echo "== fuzz_$t"
      grep -v '^#[0-9]' "$out/$t/log" | tail -40
    fi
  done
  exit 1
fi
