#!/usr/bin/env bash
# Runs every measurement of docs/RESULTS.md, then regenerates it with scripts/make_results.py.
#
#   bash scripts/measure_results.sh [path/to/mctstereo]     (from anywhere; default build/release/apps/mctstereo)
#
# Writes docs/results/*.json, the eval previews under build/results/previews (full size, not committed:
# make_results.py composes the few it shows into docs/images/previews_*.png), docs/RESULTS.md and
# docs/images/*.png. Without ../shared/data (the Middlebury scenes) the evaluation steps 1-3 are
# skipped and the JSON files already in docs/results are used. Keep the machine otherwise idle: the
# benchmarks time wall-clock frames. PYTHON picks the interpreter of make_results.py (it needs matplotlib).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
binary=${1:-build/release/apps/mctstereo}
results=docs/results
previews=build/results/previews
data=../shared/data
presets=realtime,balanced,quality,sgm-full,mct-full,mr-mct-full,mr-mct-5x5

if [[ ! -x $binary ]]; then
  echo "measure_results.sh: '$binary' is not an executable: build it (cmake --preset release &&" \
    "cmake --build --preset release) or give its path" >&2
  exit 2
fi

# The interpreter is checked first, so that a missing matplotlib does not waste the measurements.
python=${PYTHON:-}
if [[ -z $python ]]; then
  for candidate in python3 /usr/bin/python3; do
    if command -v "$candidate" >/dev/null 2>&1 && "$candidate" -c 'import matplotlib, numpy' 2>/dev/null; then
      python=$candidate
      break
    fi
  done
fi
if [[ -z $python ]] || ! "$python" -c 'import matplotlib, numpy' 2>/dev/null; then
  echo "measure_results.sh: no python3 with matplotlib and numpy (Debian: apt-get install python3-matplotlib;" \
    "or set PYTHON)" >&2
  exit 2
fi

run() {
  echo "+ $*" >&2
  "$@"
}

mkdir -p "$results" "$previews"

# 1-3: quality on Middlebury 2003 and 2005/2006, and the exposure study.
if [[ -d $data/middlebury2003 ]]; then
  run "$binary" eval "$data/middlebury2003" --preset "$presets" --peers --repeat 5 -q \
    --save "$previews" --json "$results/eval_middlebury2003.json"
else
  echo "measure_results.sh: note: $data/middlebury2003 is absent: steps 1 and 3 skipped," \
    "keeping $results/eval_middlebury2003.json and eval_radiometric.json" >&2
fi
if [[ -d $data/middlebury2005 ]]; then
  run "$binary" eval "$data/middlebury2005" --preset "$presets" --peers --repeat 5 -q \
    --save "$previews" --json "$results/eval_middlebury2005.json"
else
  echo "measure_results.sh: note: $data/middlebury2005 is absent: step 2 skipped," \
    "keeping $results/eval_middlebury2005.json" >&2
fi
if [[ -d $data/middlebury2003 ]]; then
  run "$binary" eval "$data/middlebury2003" --radiometric --peers -q --json "$results/eval_radiometric.json"
fi

# 4-6: speed on the bundled Tsukuba pair resized to each size.
run "$binary" bench --data data --sizes 640x480 --num-disparities 64 --threads 2 \
  --json "$results/bench_640x480.json"
# The targets' ratios are the median of three runs: two more of the presets they name.
for repeat in 2 3; do
  run "$binary" bench --data data --sizes 640x480 --num-disparities 64 --threads 2 \
    --presets realtime,balanced,quality --json "$results/bench_640x480_repeat$repeat.json"
done
run "$binary" bench --data data --sizes thesis --num-disparities 64,128,256 --threads 1,2 \
  --presets realtime,balanced,quality --json "$results/bench_thesis.json"
run "$binary" bench --data data --sizes 320x240,640x480 --num-disparities 64 --threads 1 \
  --backend reference,cpu --presets realtime,quality --json "$results/bench_backends.json"

# 7: the opencl backend (PoCL on a CPU, or the first GPU) against the cpu backend.
run "$binary" bench --data data --sizes thesis --num-disparities 64 --threads 2 --backend cpu,opencl \
  --presets realtime,quality --json "$results/bench_opencl.json"

# 8: a loaded CPU: two busy threads of another process while every method is timed; three runs, since
# where the OS places a lone thread changes from run to run.
run "$binary" bench --data data --sizes 640x480 --num-disparities 64 --threads 1,2 --load 2 \
  --presets realtime,balanced,quality --json "$results/bench_loaded.json"
for repeat in 2 3; do
  run "$binary" bench --data data --sizes 640x480 --num-disparities 64 --threads 1,2 --load 2 \
    --presets realtime,balanced,quality --json "$results/bench_loaded_repeat$repeat.json"
done

# 9: the cost per pixel from 640x480 to 4K on frames of the pair repeated at its own size, and the
# matching work per pixel-disparity pair (the roofline).
run "$binary" bench --data data --sizes 640x480,3840x2160 --fit tile --num-disparities 64,256 --threads 1,2 \
  --presets realtime --json "$results/bench_scaling.json"

# 11: memory: a fresh process per size, range and preset (no timing).
run "$binary" bench --data data --memory-only --sizes thesis --num-disparities 64,128,256 --threads 2 \
  --presets realtime,balanced,quality --json "$results/bench_memory.json"

# 10: streams: the temporal prior on still and panning sequences made from the Middlebury scenes
# (the bundled Tsukuba pair without ../shared/data).
sequence_binary=$(dirname "$(dirname "$binary")")/bench/mctstereo_sequence_benchmark
if [[ ! -x $sequence_binary ]]; then
  echo "measure_results.sh: '$sequence_binary' is not an executable: build the benchmarks" >&2
  exit 2
fi
if [[ -d $data/middlebury2003 ]]; then
  sequence_scenes=("$data"/middlebury2003/* "$data"/middlebury2005/*)
else
  sequence_scenes=(data/tsukuba)
fi
run "$sequence_binary" "${sequence_scenes[@]}" --presets balanced,quality --frames 30 --pan-speeds 1,12 \
  --threads 2 --json "$results/sequence_temporal.json"

run "$python" scripts/make_results.py --results "$results" --previews "$previews"
