// Helpers shared by the tests: seeded random images and maps, plane comparison, SIMD target loops,
// the sizes and variants every backend's stage tests run.
#pragma once

#include <gtest/gtest.h>
#include <hwy/targets.h>
#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <random>
#include <string>
#include <vector>

#include "plane.hpp"
#include "stages.hpp"

namespace mctstereo::test {

using detail::Plane;

/// Band SGM at every level, the finest with a wide band (radius 6, up to 32 candidates), uniqueness
/// 10 % and speckles under 100 px: the most SGM work a preset-like configuration asks for (SGM's
/// finest level at full resolution, its segments, a band wider than one vector), which `quality`
/// no longer does since its finest level matches with box sums.
inline StereoParams sgm_every_level() {
  StereoParams p = preset("quality");
  p.box_levels = 0;
  p.finest_search_radius = 6;
  p.uniqueness_ratio = 10;
  p.speckle_size = 100;
  return p;
}

/// A W x H gray plane of seeded uniform noise; `pad` as in Plane (stride is padded anyway).
inline Plane<std::uint8_t> random_image(int w, int h, std::uint32_t seed, int pad = 0) {
  Plane<std::uint8_t> p(w, h, pad);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> dist(0, 255);
  for (int y = 0; y < h; ++y)
    for (int x = -pad; x < w + pad; ++x) p.row(y)[x] = static_cast<std::uint8_t>(dist(rng));
  return p;
}

/// Smooth-ish random texture (sum of a few noise octaves), closer to real images than pure noise.
inline Plane<std::uint8_t> random_texture(int w, int h, std::uint32_t seed) {
  Plane<std::uint8_t> p(w, h);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> dist(0, 255);
  std::vector<int> coarse(((w + 3) / 4 + 2) * ((h + 3) / 4 + 2));
  for (int& c : coarse) c = dist(rng);
  const int cw = (w + 3) / 4 + 2;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = (coarse[(y / 4) * cw + x / 4] * 3 + dist(rng)) / 4;
      p.at(x, y) = static_cast<std::uint8_t>(v);
    }
  return p;
}

/// A disparity-like int16 plane: random values in [lo, hi] (whole pixels in Q4 when q4_whole),
/// a fraction `invalid_fraction` of kInvalid, in blocks so that regions and runs appear.
inline Plane<std::int16_t> random_disparity(int w, int h, std::uint32_t seed, int lo, int hi,
                                            double invalid_fraction = 0.1, bool q4_whole = false) {
  Plane<std::int16_t> p(w, h);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> dist(lo, hi);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      int v = dist(rng);
      if (q4_whole) v = 16 * (v / 16);
      p.at(x, y) = u(rng) < invalid_fraction ? detail::kInvalid : static_cast<std::int16_t>(v);
    }
  return p;
}

/// A w x h map of the given values, row after row.
inline Plane<std::int16_t> make_map(int w, int h, std::initializer_list<std::int16_t> values) {
  Plane<std::int16_t> p(w, h);
  auto it = values.begin();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) p.at(x, y) = *it++;
  return p;
}

/// The pixels of a map, row after row.
inline std::vector<std::int16_t> pixels(const Plane<std::int16_t>& p) {
  std::vector<std::int16_t> v;
  for (int y = 0; y < p.height(); ++y)
    for (int x = 0; x < p.width(); ++x) v.push_back(p.at(x, y));
  return v;
}

inline int count_invalid(const Plane<std::int16_t>& p) {
  int n = 0;
  for (int y = 0; y < p.height(); ++y)
    for (int x = 0; x < p.width(); ++x) n += p.at(x, y) == detail::kInvalid;
  return n;
}

/// The kinds of random_disparity() map the refinement comparisons run on: (invalid fraction,
/// whole pixels or fractional Q4).
struct MapKind {
  double invalid;
  bool whole;
};
constexpr MapKind kMapKinds[] = {{0.0, false}, {0.1, false}, {0.1, true}, {0.6, true}, {1.0, false}};

/// A map like a real one: piecewise constant disparities (steps every `step_px` pixels, so vectors
/// meet depth edges) with sub-pixel noise that crosses the rounding point (16 k + 7 vs 16 k + 8)
/// and 5 % invalid pixels.
inline Plane<std::int16_t> smooth_disparity(int w, int h, std::uint32_t seed, int base_q4, int step_px,
                                            int noise_q4) {
  Plane<std::int16_t> p(w, h);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-noise_q4, noise_q4), invalid(0, 19), level(0, 5);
  for (int y = 0; y < h; ++y) {
    int v = base_q4;
    for (int x = 0; x < w; ++x) {
      if (x % step_px == 0) v = base_q4 + 16 * level(rng) + 8 * (level(rng) % 2);
      p.at(x, y) = invalid(rng) == 0 ? detail::kInvalid : static_cast<std::int16_t>(v + noise(rng));
    }
  }
  return p;
}

/// fill_invalid's known answers on single rows.
struct FillCase {
  FillMode mode;
  std::vector<std::int16_t> in, out;
};
inline std::vector<FillCase> fill_known_answers() {
  constexpr std::int16_t I = detail::kInvalid;
  return {
      {FillMode::None, {5, I, I, I, 9}, {5, I, I, I, 9}},
      // Odd run: the middle pixel is as far from 5 as from 9 and takes the smaller.
      {FillMode::Nearest, {5, I, I, I, 9}, {5, 5, 5, 9, 9}},
      {FillMode::Nearest, {9, I, I, I, 5}, {9, 9, 5, 5, 5}},
      {FillMode::Nearest, {9, I, I, I, I, 5}, {9, 9, 9, 5, 5, 5}},
      {FillMode::NearestLower, {5, I, I, I, 9}, {5, 5, 5, 5, 9}},
      {FillMode::NearestLower, {9, I, -3, I, I, 7}, {9, -3, -3, -3, -3, 7}},
      // Runs touching a border take the one neighbour they have; an all-invalid row stays so.
      {FillMode::Nearest, {I, I, 7, I, 4, I}, {7, 7, 7, 4, 4, 4}},
      {FillMode::NearestLower, {I, I, 7, I, 4, I}, {7, 7, 7, 4, 4, 4}},
      {FillMode::Nearest, {I, I, I}, {I, I, I}},
      {FillMode::NearestLower, {I, I, I}, {I, I, I}},
  };
}

/// The two pairs of random_disparity() maps of a kind the LR check comparisons run on: wide, and
/// disparities up to 40 px against widths down to 1, so that partners fall both inside and
/// outside the image; the narrow value range makes agreement within the threshold common.
struct LrCheckMaps {
  Plane<std::int16_t> src, other, narrow, narrow_other;
};
inline LrCheckMaps lr_check_maps(int w, int h, std::uint32_t& seed, const MapKind& kind) {
  LrCheckMaps m{random_disparity(w, h, ++seed, -160, 640, kind.invalid, kind.whole),
                random_disparity(w, h, ++seed, -160, 640, kind.invalid / 2, kind.whole),
                random_disparity(w, h, ++seed, 0, 40, kind.invalid, kind.whole),
                random_disparity(w, h, ++seed, 0, 40, kind.invalid, kind.whole)};
  return m;
}

/// (base_q4, step_px) of the smooth_disparity() maps the LR check comparisons run on: positive
/// and negative disparities, narrow and wide steps, and values at the int16 limits (the rounding
/// of 32760 must not overflow; partners of huge disparities leave the image).
constexpr std::pair<int, int> kLrCheckMapShapes[] = {
    {16 * 3, 13}, {16 * -9, 40}, {16 * 20, 7}, {32760 - 16 * 6, 50}, {-32768 + 16 * 1, 50}};

/// 40 RGB pixels of varied channels and their luma, (77 R + 150 G + 29 B + 128) >> 8: whole
/// vectors and a tail on every backend.
struct KnownLuma {
  std::vector<std::uint8_t> rgb;
  std::vector<int> luma;
};
inline KnownLuma known_luma_row() {
  KnownLuma k;
  for (int i = 0; i < 40; ++i) {
    const int r = (i * 37) % 256, g = (i * 91 + 7) % 256, b = 255 - (i * 13) % 256;
    for (int c : {r, g, b}) k.rgb.push_back(static_cast<std::uint8_t>(c));
    k.luma.push_back((77 * r + 150 * g + 29 * b + 128) >> 8);
  }
  return k;
}

/// Pixels from four grey levels only: many neighbours equal the centre, and many 3x3 sums are
/// exact multiples of the norm, the cases where "<" and "<=" (or a rounded mean) would differ.
inline Plane<std::uint8_t> few_levels_image(int w, int h, std::uint32_t seed) {
  Plane<std::uint8_t> p(w, h);
  std::mt19937 rng(seed);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) p.at(x, y) = static_cast<std::uint8_t>(100 + rng() % 4);
  return p;
}

/// A rectified-looking pair: `right` is `left` moved `shift` pixels to the left (x_R = x_L -
/// shift) plus mild noise, so that costs have clear minima (sub-pixel and uniqueness then have
/// work).
struct ShiftedPair {
  Plane<std::uint8_t> left, right;
};
inline ShiftedPair shifted_pair(int w, int h, std::uint32_t seed, int shift) {
  ShiftedPair p{random_texture(w, h, seed), Plane<std::uint8_t>(w, h)};
  const Plane<std::uint8_t> noise = random_image(w, h, seed + 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = p.left.at(detail::clamp_index(x + shift, w), y) + (noise.at(x, y) % 9) - 4;
      p.right.at(x, y) = static_cast<std::uint8_t>(std::clamp(v, 0, 255));
    }
  return p;
}

/// Census code planes for a w x h image and an n x n window, with the pad columns the host
/// stages write.
inline detail::CensusCodes code_planes(int w, int h, int window) {
  detail::CensusCodes codes;
  codes.words = detail::census_words(window);
  for (int k = 0; k < codes.words; ++k) codes.plane[k].reset(w, h, detail::kCodePad);
  return codes;
}

/// reference::census_transform of `image` (MCT with the Gaussian mean).
inline detail::CensusCodes reference_census(const Plane<std::uint8_t>& image, int window, CensusKind kind) {
  detail::CensusCodes codes = code_planes(image.width(), image.height(), window);
  detail::reference::census_transform(image, {kind, window, MeanKernel::Gaussian}, codes);
  return codes;
}

/// Every census variant: CT, and MCT with either mean kernel, for each window.
inline std::vector<detail::CensusConfig> all_census_configs() {
  std::vector<detail::CensusConfig> configs;
  for (int window : {3, 5, 7, 9}) {
    configs.push_back({CensusKind::Census, window, MeanKernel::Box});
    configs.push_back({CensusKind::ModifiedCensus, window, MeanKernel::Box});
    configs.push_back({CensusKind::ModifiedCensus, window, MeanKernel::Gaussian});
  }
  return configs;
}

/// "CT5x5", "MCT7x7Box", "MCT9x9Gaussian": an identifier, so it can name a test.
inline std::string census_config_name(const detail::CensusConfig& c) {
  const std::string n = std::to_string(c.window);
  if (c.kind == CensusKind::Census) return "CT" + n + "x" + n;
  return "MCT" + n + "x" + n + (c.kernel == MeanKernel::Box ? "Box" : "Gaussian");
}

inline const char* format_name(PixelFormat f) {
  return f == PixelFormat::Gray8 ? "gray8" : f == PixelFormat::Rgb8 ? "rgb8" : "bgr8";
}

/// An interleaved input image of seeded random bytes whose rows are `extra` bytes longer than the
/// pixels. The buffer ends right after the last pixel, as a caller's image may.
struct RandomInput {
  std::vector<std::uint8_t> bytes;
  ImageView view;
  RandomInput(int w, int h, PixelFormat format, int extra, std::uint32_t seed) {
    const std::ptrdiff_t stride = static_cast<std::ptrdiff_t>(w) * bytes_per_pixel(format) + extra;
    bytes.resize(static_cast<std::size_t>(stride * (h - 1) + w * bytes_per_pixel(format)));
    std::mt19937 rng(seed);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    view = {bytes.data(), w, h, stride, format};
  }
};

/// Index of the first differing pixel as "(x, y): a vs b", or empty when equal (pixels only).
template <typename T>
std::string first_difference(const Plane<T>& a, const Plane<T>& b) {
  if (a.width() != b.width() || a.height() != b.height())
    return "sizes differ: " + std::to_string(a.width()) + "x" + std::to_string(a.height()) + " vs " +
           std::to_string(b.width()) + "x" + std::to_string(b.height());
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      if (a.at(x, y) != b.at(x, y))
        return "(" + std::to_string(x) + ", " + std::to_string(y) + "): " + std::to_string(+a.at(x, y)) +
               " vs " + std::to_string(+b.at(x, y));
  return {};
}

/// Runs fn once per SIMD target compiled in and supported here, with dynamic dispatch forced to
/// that target; restores the normal choice afterwards. fn receives the target's name.
inline void for_each_simd_target(const std::function<void(const std::string&)>& fn) {
  for (std::int64_t target : hwy::SupportedAndGeneratedTargets()) {
    hwy::SetSupportedTargetsForTest(target);
    fn(hwy::TargetName(target));
  }
  hwy::SetSupportedTargetsForTest(0);
}

/// Runs fn on every SIMD target the tests compile, plus AVX3_DL (which the library compiles on its
/// own for the matching stages) where this CPU has it.
inline void for_each_library_target(const std::function<void(const std::string&)>& fn) {
  for_each_simd_target(fn);
  if (hwy::SupportedTargets() & HWY_AVX3_DL) {
    hwy::SetSupportedTargetsForTest(HWY_AVX3_DL);
    fn(hwy::TargetName(HWY_AVX3_DL));
    hwy::SetSupportedTargetsForTest(0);
  }
}

/// A stage's per-thread scratch (MatchScratch, SgmScratch): `threads` slices of bytes_per_thread
/// bytes each, taken as given (the driver rounds them to 64 bytes; a test may leave them odd).
template <class Scratch>
Scratch thread_scratch(std::size_t bytes_per_thread, int threads) {
  Scratch s;
  s.threads = threads;
  s.bytes_per_thread = bytes_per_thread;
  s.data = detail::allocate_aligned<std::uint8_t>(s.bytes_per_thread * threads);
  return s;
}

/// n rounded up to whole 64-byte lines, as the driver sizes scratch slices.
inline std::size_t whole_lines(std::size_t n) { return (n + 63) / 64 * 64; }

/// Runs fn with 1 and then 2 OpenMP threads, and restores the count; fn receives "N thread(s)"
/// for its messages. For stages without SIMD dispatch.
inline void for_one_and_two_threads(const std::function<void(const std::string&)>& fn) {
  const int saved = omp_get_max_threads();
  for (int threads : {1, 2}) {
    omp_set_num_threads(threads);
    fn(std::to_string(threads) + " thread(s)");
  }
  omp_set_num_threads(saved);
}

/// Runs fn on every SIMD target (as for_each_simd_target) with 1 and then 2 OpenMP threads;
/// fn receives "TARGET, N thread(s)" for its messages.
inline void for_each_target_and_threads(const std::function<void(const std::string&)>& fn) {
  for_each_simd_target([&](const std::string& target) {
    for_one_and_two_threads([&](const std::string& threads) { fn(target + ", " + threads); });
  });
}

/// Awkward sizes every stage test runs: odd, tiny, one column, one row, around vector widths.
inline std::vector<std::pair<int, int>> awkward_sizes() {
  return {{631, 479}, {17, 5}, {1, 64}, {64, 1}, {2, 2}, {15, 9}, {16, 9}, {31, 7},
          {32, 7}, {33, 7}, {63, 4}, {64, 4}, {65, 4}, {127, 3}, {129, 3}};
}

/// The sizes the pyramid reductions run: awkward_sizes(), 1 x N and N x 1 of both parities, rows
/// longer than one pass of 512 output columns (cpu), and widths on either side of the
/// whole-vector condition 2 x0 + 33 < W of the opencl work-item at x0 = 16 (65, 66) and x0 = 32
/// (97, 98).
inline std::vector<std::pair<int, int>> pyramid_sizes() {
  std::vector<std::pair<int, int>> sizes = awkward_sizes();
  sizes.insert(sizes.end(), {{1, 1}, {1, 7}, {7, 1}, {2, 1}, {1, 2}, {3, 3}, {4, 5}, {1025, 3}, {1100, 4}, {65, 3},
                             {66, 3}, {97, 2}, {98, 2}});
  return sizes;
}

}  // namespace mctstereo::test
