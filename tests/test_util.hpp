// Helpers shared by the tests: seeded random images, plane comparison, SIMD target loops.
#pragma once

#include <gtest/gtest.h>
#include <hwy/targets.h>
#include <omp.h>

#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "plane.hpp"
#include "stages.hpp"

namespace mctstereo::test {

using detail::Plane;

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

/// Runs fn on every SIMD target (as for_each_simd_target) with 1 and then 2 OpenMP threads;
/// fn receives "TARGET, N thread(s)" for its messages.
inline void for_each_target_and_threads(const std::function<void(const std::string&)>& fn) {
  const int saved = omp_get_max_threads();
  for_each_simd_target([&](const std::string& target) {
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      fn(target + ", " + std::to_string(threads) + " thread(s)");
    }
  });
  omp_set_num_threads(saved);
}

/// Awkward sizes every stage test runs: odd, tiny, one column, one row, around vector widths.
inline std::vector<std::pair<int, int>> awkward_sizes() {
  return {{631, 479}, {17, 5}, {1, 64}, {64, 1}, {2, 2}, {15, 9}, {16, 9}, {31, 7},
          {32, 7}, {33, 7}, {63, 4}, {64, 4}, {65, 4}, {127, 3}, {129, 3}};
}

}  // namespace mctstereo::test
