#!/bin/bash
# A long run of `mctstereo stream` on synthetic frames (--synthetic: made in the process, never
# stored) that samples the process's resident memory (VmRSS of /proc/PID/status) and its open file
# descriptors (/proc/PID/fd) while it runs. Each frame's disparity map is written as a 16-bit PNG
# (so the output path is exercised) and deleted by this script once written, so the disk stays
# flat. Fails unless the stream ends well with FRAMES frames, the resident memory after the
# warm-up (the first tenth of the frames) stays within 1 MiB, and the descriptors do not grow:
# after the warm-up a sample may find one more than the fewest (the map being written at that
# moment), never more, and the fewest of the last tenth of the samples is the fewest of all.
#
# Usage: scripts/soak.sh [FRAMES [SIZE [BUILD [MORE STREAM FLAGS...]]]]
#   defaults: 20000 frames, 320x240, build/release (cmake --preset release && cmake --build --preset release)
# Not part of CI (it takes minutes); docs/RELIABILITY.md records the last run.
set -euo pipefail
cd "$(dirname "$0")/.."
frames=${1:-20000}
size=${2:-320x240}
build=${3:-build/release}
shift $(($# < 3 ? $# : 3))
program="$build/apps/mctstereo"
[ -x "$program" ] || { echo "soak: $program is missing (build the preset first)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/out"

"$program" stream --synthetic "$size" --max-frames "$frames" --num-disparities 16 --threads 2 --quiet \
  --disparity "$work/out/d%06d.png" "$@" > "$work/summary" 2> "$work/stderr" &
pid=$!
echo "soak: stream pid $pid, $frames frames $size, sampling every second"
printf '%8s %8s %10s %4s\n' seconds frames rss_kib fds > "$work/samples"
written=0
start=$SECONDS
while kill -0 "$pid" 2> /dev/null; do
  rss=$(awk '/^VmRSS:/ {print $2}' "/proc/$pid/status" 2> /dev/null || true)
  fds=$(ls "/proc/$pid/fd" 2> /dev/null | wc -l || true)
  # Completed maps only: temporaries are hidden names beginning with a dot.
  # Counted and deleted from one listing: a map written in between is counted at the next sample.
  mapfile -t maps < <(find "$work/out" -name 'd*.png')
  [ "${#maps[@]}" = 0 ] || rm -f "${maps[@]}"
  written=$((written + ${#maps[@]}))
  [ -n "$rss" ] && printf '%8d %8d %10d %4d\n' $((SECONDS - start)) "$written" "$rss" "$fds" >> "$work/samples"
  sleep 1
done
status=0
wait "$pid" || status=$?
written=$((written + $(find "$work/out" -name 'd*.png' | wc -l)))
cat "$work/samples"
cat "$work/summary"
if [ "$status" != 0 ]; then
  echo "soak: FAILED: stream exited with status $status" >&2
  cat "$work/stderr" >&2
  exit 1
fi
grep -q "^$frames frames $size" "$work/summary" || { echo "soak: FAILED: the summary does not say $frames frames" >&2; exit 1; }
[ "$written" = "$frames" ] || { echo "soak: FAILED: $written maps written, expected $frames" >&2; exit 1; }
# After the warm-up: the samples taken once a tenth of the frames was written.
awk -v warm=$((frames / 10)) '
  NR > 1 && $2 >= warm {
    n++
    if (n == 1) { min = $3; max = $3; fdmin = $4; fdmax = $4 }
    if ($3 < min) min = $3
    if ($3 > max) max = $3
    if ($4 < fdmin) fdmin = $4
    if ($4 > fdmax) fdmax = $4
    fds[n] = $4
  }
  END {
    if (n < 10) { print "soak: FAILED: only " n " samples after the warm-up (run more frames)"; exit 1 }
    last = fds[n]
    for (i = n - int(n / 10); i <= n; i++) if (fds[i] < last) last = fds[i]
    printf "soak: %d samples after the warm-up: VmRSS %d..%d KiB (spread %d KiB), open fds %d..%d (fewest in the last tenth %d)\n", n, min, max, max - min, fdmin, fdmax, last
    if (max - min > 1024) { print "soak: FAILED: resident memory grew by more than 1 MiB"; exit 1 }
    if (fdmax > fdmin + 1 || last > fdmin) { print "soak: FAILED: file descriptors grew"; exit 1 }
  }' "$work/samples"
echo "soak: passed"
