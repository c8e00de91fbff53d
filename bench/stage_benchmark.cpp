// Time of single stages on synthetic inputs, for the choices a stage's implementation made.
// Internal API (src/stages.hpp). Run: mctstereo_stage_benchmarks [--benchmark_filter=...].
//
// The colour-weighted median (docs/PIPELINE.md) by its three exact methods: the cpu stage (a
// vector binary search), a scalar per-pixel histogram and a scalar per-pixel sort; the reference
// for scale. The map is piecewise constant with sub-pixel noise and 5 % invalid pixels (the
// shape of a map after the fill and before it: whole disparities over ~40 px), the colour a
// smooth random texture, at 450 x 375 (Middlebury 2003) and 640 x 480, 1 thread and all; then
// whole frames with and without the stage.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <array>
#include <cstdint>
#include <random>
#include <vector>
#include <algorithm>

#include "mctstereo/mctstereo.hpp"
#include "stages.hpp"

namespace {

using mctstereo::detail::ColourPlanes;
using mctstereo::detail::kInvalid;
using mctstereo::detail::Plane;
using mctstereo::detail::WeightedMedianConfig;
namespace detail = mctstereo::detail;

struct Inputs {
  Plane<std::int16_t> map, out;
  std::array<Plane<std::uint8_t>, 3> colour;
  ColourPlanes view;
  WeightedMedianConfig config;
};

Inputs make_inputs(int w, int h) {
  Inputs in;
  in.map.reset(w, h);
  in.out.reset(w, h);
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> level(0, 40), noise(-12, 12), invalid(0, 19), byte(0, 255);
  for (int y = 0; y < h; ++y) {
    int v = 0;
    for (int x = 0; x < w; ++x) {
      if (x % 23 == 0 || (y % 17 == 0 && x % 5 == 0)) v = 16 * level(rng);
      in.map.at(x, y) = invalid(rng) == 0 ? kInvalid : static_cast<std::int16_t>(v + noise(rng));
    }
  }
  for (int c = 0; c < 3; ++c) {
    in.colour[c].reset(w, h);
    std::vector<int> coarse(((w + 7) / 8 + 1) * ((h + 7) / 8 + 1));
    for (int& v : coarse) v = byte(rng);
    const int cw = (w + 7) / 8 + 1;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        in.colour[c].at(x, y) = static_cast<std::uint8_t>((3 * coarse[(y / 8) * cw + x / 8] + byte(rng) % 32) / 3 % 256);
    in.view.plane[c] = &in.colour[c];
  }
  in.view.channels = 3;
  in.config.radius = 9;
  in.config.step = 3;
  in.config.lut = detail::weighted_median_lut(10);
  return in;
}

enum Method { kVector, kHistogram, kSort, kReference };

// radius 9, step 3, sigma 10 (the design's window) unless `presets`: radius 6, step 2, sigma 15.
void weighted_median(benchmark::State& state, Method method, int w, int h, int threads, bool presets = false) {
  Inputs in = make_inputs(w, h);
  if (presets) {
    in.config.radius = 6;
    in.config.step = 2;
    in.config.lut = detail::weighted_median_lut(15);
  }
  const int saved = omp_get_max_threads();
  omp_set_num_threads(threads > 0 ? threads : saved);
  for (auto _ : state) {
    switch (method) {
      case kVector: detail::cpu::weighted_median(in.map, in.view, in.config, in.out); break;
      case kHistogram:
        detail::cpu::weighted_median_scalar(in.map, in.view, in.config, detail::cpu::WeightedMedianMethod::Histogram,
                                            in.out);
        break;
      case kSort:
        detail::cpu::weighted_median_scalar(in.map, in.view, in.config, detail::cpu::WeightedMedianMethod::Sort, in.out);
        break;
      case kReference: detail::reference::weighted_median(in.map, in.view, in.config, in.out); break;
    }
    benchmark::DoNotOptimize(in.out.row(0));
  }
  omp_set_num_threads(saved);
  state.counters["Mpx/s"] = benchmark::Counter(static_cast<double>(w) * h, benchmark::Counter::kIsIterationInvariantRate);
  state.SetLabel(detail::cpu::simd_target_name());
}

#define WM_BENCH(name, method, w, h, threads) \
  BENCHMARK_CAPTURE(weighted_median, name, method, w, h, threads)->Unit(benchmark::kMillisecond)->UseRealTime()

WM_BENCH(vector_450x375_1t, kVector, 450, 375, 1);
WM_BENCH(histogram_450x375_1t, kHistogram, 450, 375, 1);
WM_BENCH(sort_450x375_1t, kSort, 450, 375, 1);
WM_BENCH(reference_450x375, kReference, 450, 375, 1);
WM_BENCH(vector_640x480_1t, kVector, 640, 480, 1);
WM_BENCH(histogram_640x480_1t, kHistogram, 640, 480, 1);
WM_BENCH(sort_640x480_1t, kSort, 640, 480, 1);
WM_BENCH(vector_640x480_all, kVector, 640, 480, 0);
WM_BENCH(histogram_640x480_all, kHistogram, 640, 480, 0);
WM_BENCH(sort_640x480_all, kSort, 640, 480, 0);
BENCHMARK_CAPTURE(weighted_median, vector_640x480_1t_presets_window, kVector, 640, 480, 1, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(weighted_median, histogram_640x480_1t_presets_window, kHistogram, 640, 480, 1, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(weighted_median, sort_640x480_1t_presets_window, kSort, 640, 480, 1, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The whole frame of a preset with and without the stage (colour input, cpu backend, all
// threads): the difference is the stage with its 3x3 median, less the post-fill median 5 it
// replaces at the finest level.
void frame(benchmark::State& state, const char* preset, bool weighted_median, int w, int h) {
  Inputs in = make_inputs(w, h);
  std::vector<std::uint8_t> left(static_cast<std::size_t>(w) * h * 3), right(static_cast<std::size_t>(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) left[(static_cast<std::size_t>(y) * w + x) * 3 + c] = in.colour[c].at(x, y);
      right[static_cast<std::size_t>(y) * w + x] = in.colour[1].at(std::min(x + 8 + x / 64, w - 1), y);
    }
  mctstereo::StereoParams p = mctstereo::preset(preset);
  p.num_disparities = 64;
  p.weighted_median = weighted_median;
  mctstereo::Matcher m(w, h, p, mctstereo::Backend::Cpu);
  const mctstereo::ImageView l{left.data(), w, h, 3 * w, mctstereo::PixelFormat::Rgb8};
  const mctstereo::ImageView r{right.data(), w, h, w, mctstereo::PixelFormat::Gray8};
  for (auto _ : state) {
    m.compute(l, r);
    benchmark::DoNotOptimize(m.disparity_q4().data);
  }
}
BENCHMARK_CAPTURE(frame, balanced_640x480, "balanced", true, 640, 480)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(frame, balanced_no_wm_640x480, "balanced", false, 640, 480)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(frame, quality_640x480, "quality", true, 640, 480)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(frame, quality_no_wm_640x480, "quality", false, 640, 480)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
