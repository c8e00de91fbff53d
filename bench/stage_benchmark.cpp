// Time of single stages on synthetic inputs, for the choices a stage's implementation made.
// Internal API (src/stages.hpp). Run: mctstereo_stage_benchmarks [--benchmark_filter=...].
//
// The colour-weighted median (docs/PIPELINE.md) by its three exact methods: the cpu stage (a
// vector binary search), a scalar per-pixel histogram and a scalar per-pixel sort; the reference
// for scale. The map is piecewise constant with sub-pixel noise and 5 % invalid pixels (the
// shape of a map after the fill and before it: whole disparities over ~40 px), the colour a
// smooth random texture, at 450 x 375 (Middlebury 2003) and 640 x 480, 1 thread and all; then
// whole frames with and without the stage.
//
// Band SGM's three stages (costs, paths, winners) at the finest level of SGM at every level (`quality`
// with `--box-levels 0 --finest-radius 6 --uniqueness 10 --speckle-size 100`): 640 x 480 with
// 64 disparities, a prior from the 320 x 240 level below, radius 6, bands of up to 32 candidates,
// CT 5x5 with 3x3 boxes (byte costs), 4 paths with the preset's penalties, uniqueness 10 %, both
// views; 1 thread and all. The scene: a textured background at 12 px with a nearer square at 40 px
// and a slanted strip, so that the bands widen at depth edges as on real maps.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "cpu/sgm_segments.hpp"
#include "mctstereo/mctstereo.hpp"
#include "level_plan.hpp"
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

// SGM at every level, the finest with radius 6 (up to 32 candidates) and uniqueness 10 %.
mctstereo::StereoParams sgm_every_level() {
  mctstereo::StereoParams p = mctstereo::preset("quality");
  p.box_levels = 0;
  p.finest_search_radius = 6;
  p.uniqueness_ratio = 10;
  p.speckle_size = 100;
  return p;
}

// The finest level of SGM at every level at w x h, ready for any of its stages: codes of both
// views, the coarser level's map as the prior, the volume with its storage, and the stages' scratch.
struct SgmLevel {
  int w, h;
  mctstereo::StereoParams params = sgm_every_level();
  Plane<std::uint8_t> left, right;
  detail::CensusCodes codes[2];
  Plane<std::int16_t> prior, map[2];
  Plane<std::uint8_t> margin;
  detail::SgmVolume volume;
  std::unique_ptr<std::uint8_t[], detail::FreeDeleter> cost;
  std::unique_ptr<std::uint16_t[], detail::FreeDeleter> sum;
  detail::SgmScratch scratch;

  // The true disparity of (x, y).
  static int disparity(int x, int y, int w, int h) {
    if (x >= w / 4 && x < w / 2 && y >= h / 4 && y < 3 * h / 4) return 40;
    if (x >= 5 * w / 8 && x < 7 * w / 8) return 12 + (y * 24) / h;
    return 12;
  }

  SgmLevel(int width, int height, int threads) : w(width), h(height) {
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> byte(0, 255), noise(-6, 6);
    left.reset(w, h);
    right.reset(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) left.at(x, y) = static_cast<std::uint8_t>(byte(rng));
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const int xl = std::min(x + disparity(std::min(x + 12, w - 1), y, w, h), w - 1);
        right.at(x, y) = left.at(xl, y);
      }
    for (int v = 0; v < 2; ++v) {
      codes[v].words = detail::census_words(params.census_window);
      for (int k = 0; k < codes[v].words; ++k) codes[v].plane[k].reset(w, h, detail::kCodePad);
      detail::cpu::census_transform(v == 0 ? left : right, {params.census, params.census_window, params.mct_kernel},
                                    codes[v]);
      map[v].reset(w, h);
    }
    // The coarser level's map: half the disparities in Q4, with sub-pixel noise.
    const int cw = (w + 1) / 2, ch = (h + 1) / 2;
    prior.reset(cw, ch);
    for (int y = 0; y < ch; ++y)
      for (int x = 0; x < cw; ++x)
        prior.at(x, y) = static_cast<std::int16_t>(8 * disparity(2 * x, 2 * y, w, h) + noise(rng));
    margin.reset(w, h);
    const int band = detail::sgm_band_width(params, 0, 63, w, false);
    const std::size_t entries = detail::SgmVolume::entries_for(w, h, band);
    cost = detail::allocate_aligned<std::uint8_t>(entries);
    sum = detail::allocate_aligned<std::uint16_t>(entries);
    volume.reset(w, h, band, codes[0].words, nullptr, sum.get());
    volume.use_byte_costs(cost.get());
    scratch.threads = threads;
    scratch.bytes_per_thread = (detail::cpu::sgm_scratch_bytes(w, h, volume.stride) + 63) / 64 * 64;
    scratch.data = detail::allocate_aligned<std::uint8_t>(scratch.bytes_per_thread * threads);
  }
  void costs() {
    const detail::SgmBandConfig band{0, 63, params.finest_radius(), params.prior_size, volume.band, {}};
    detail::cpu::sgm_costs(codes[0], codes[1], &prior, band, params.shd_window, scratch, volume);
  }
  void aggregate() {
    detail::cpu::sgm_aggregate(left, {params.sgm_paths(), params.sgm_p1, params.sgm_p2, params.sgm_p2_k}, scratch,
                               volume);
  }
  void select() {
    detail::cpu::sgm_select(volume, {params.subpixel, params.uniqueness_ratio}, scratch, map[0], &map[1], &margin);
  }
  // The costs, paths and winners of the level in two sweeps (2 threads), as the driver runs them
  // on volumes of at most cpu::kSweepVolumeLimit.
  void two_sweeps() {
    if (!states) states = detail::allocate_aligned<std::uint16_t>(detail::cpu::sgm_sweep_state_bytes(w, volume.stride) / 2);
    const detail::cpu::SgmSegmentJob job{&codes[0], &codes[1], &prior,
                                         {0, 63, params.finest_radius(), params.prior_size, volume.band, {}},
                                         params.shd_window, &left,
                                         {params.sgm_paths(), params.sgm_p1, params.sgm_p2, params.sgm_p2_k},
                                         {params.subpixel, params.uniqueness_ratio}, detail::cpu::kSweepRows,
                                         states.get(), &map[0], &map[1], &margin};
    detail::cpu::sgm_two_sweeps(job, scratch, volume);
  }
  std::unique_ptr<std::uint16_t[], detail::FreeDeleter> states;
};

// kStages: costs, paths and winners one stage after the other; kTwoSweeps: the same in two sweeps.
enum SgmStage { kCosts, kPaths, kWinners, kStages, kTwoSweeps };

void sgm(benchmark::State& state, SgmStage stage, int w, int h, int threads) {
  const int saved = omp_get_max_threads();
  const int used = threads > 0 ? threads : saved;
  omp_set_num_threads(used);
  SgmLevel level(w, h, used);
  level.costs();
  if (stage == kWinners) level.aggregate();
  for (auto _ : state) {
    switch (stage) {
      case kCosts: level.costs(); break;
      case kPaths: level.aggregate(); break;
      case kWinners: level.select(); break;
      case kStages:
        level.costs();
        level.aggregate();
        level.select();
        break;
      case kTwoSweeps: level.two_sweeps(); break;
    }
    benchmark::DoNotOptimize(level.map[0].row(0));
  }
  omp_set_num_threads(saved);
  long candidates = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) candidates += level.volume.count.at(x, y);
  state.counters["Mpx/s"] = benchmark::Counter(static_cast<double>(w) * h, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["candidates/px"] = static_cast<double>(candidates) / (static_cast<double>(w) * h);
  state.SetLabel(detail::cpu::simd_target_name());
}

#define SGM_BENCH(name, stage, w, h, threads) \
  BENCHMARK_CAPTURE(sgm, name, stage, w, h, threads)->Unit(benchmark::kMillisecond)->UseRealTime()

SGM_BENCH(costs_640x480_1t, kCosts, 640, 480, 1);
SGM_BENCH(paths_640x480_1t, kPaths, 640, 480, 1);
SGM_BENCH(winners_640x480_1t, kWinners, 640, 480, 1);
SGM_BENCH(costs_640x480_all, kCosts, 640, 480, 0);
SGM_BENCH(paths_640x480_all, kPaths, 640, 480, 0);
SGM_BENCH(winners_640x480_all, kWinners, 640, 480, 0);
SGM_BENCH(stages_320x240_2t, kStages, 320, 240, 2);
SGM_BENCH(sweeps_320x240_2t, kTwoSweeps, 320, 240, 2);
SGM_BENCH(stages_640x480_2t, kStages, 640, 480, 2);
SGM_BENCH(sweeps_640x480_2t, kTwoSweeps, 640, 480, 2);

}  // namespace

BENCHMARK_MAIN();
