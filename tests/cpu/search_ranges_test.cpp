// cpu::search_ranges equals the reference bit for bit, with and without a coarse prior, on every
// SIMD target and with 1 and 2 threads.
#include <omp.h>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;

struct Ranges {
  Plane<std::int16_t> lo, hi;
  Ranges(int w, int h, int pad) : lo(w, h, pad), hi(w, h, pad) {}
};

void expect_equal(const Plane<std::int16_t>* coarse, int w, int h, int dmin, int dmax, int radius,
                  const std::string& what) {
  Ranges expected(w, h, 0);
  detail::reference::search_ranges(coarse, dmin, dmax, radius, expected.lo, expected.hi);
  for_each_target_and_threads([&](const std::string& label) {
    Ranges got(w, h, 3);
    detail::cpu::search_ranges(coarse, dmin, dmax, radius, got.lo, got.hi);
    const std::string where = what + " " + std::to_string(w) + "x" + std::to_string(h) + " [" +
                              std::to_string(dmin) + ", " + std::to_string(dmax) + "] r " +
                              std::to_string(radius) + " " + label;
    EXPECT_EQ(first_difference(got.lo, expected.lo), "") << "lo " << where;
    EXPECT_EQ(first_difference(got.hi, expected.hi), "") << "hi " << where;
  });
}

TEST(CpuSearchRanges, WithoutPriorTheWholeRange) {
  for (auto [w, h] : awkward_sizes()) expect_equal(nullptr, w, h, -7, 33, 2, "no prior");
  for_each_target_and_threads([&](const std::string& label) {
    Ranges got(37, 3, 0);
    detail::cpu::search_ranges(nullptr, -4, 12, 1, got.lo, got.hi);
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 37; ++x) {
        ASSERT_EQ(got.lo.at(x, y), -4) << label;
        ASSERT_EQ(got.hi.at(x, y), 12) << label;
      }
  });
}

// A random prior (whole pixels in Q4, a fifth invalid) for a fine level w x h: the coarse level is
// ceil(W / 2) wide and high as the pyramid builds it, or floor(W / 2). Priors reach a little past
// the coarse level's range so that the clip to [dmin, dmax] matters on both sides.
Plane<std::int16_t> random_prior(int w, int h, bool ceil_half, int dmin, int dmax, std::uint32_t seed) {
  const int cw = ceil_half ? (w + 1) / 2 : w / 2, ch = ceil_half ? (h + 1) / 2 : h / 2;
  return random_disparity(cw, ch, seed, 16 * (dmin / 2 - 3), 16 * (dmax / 2 + 3), 0.2, true);
}

const std::pair<int, int> kRanges[] = {{0, 40}, {-30, -2}, {-9, 9}};  // positive, negative, both

TEST(CpuSearchRanges, EqualsReferenceWithRandomPriors) {
  std::uint32_t seed = 11;
  int radius = 0;
  for (auto [w, h] : awkward_sizes()) {
    for (auto [dmin, dmax] : kRanges) {
      for (bool ceil_half : {true, false}) {
        if (!ceil_half && (w == 1 || h == 1)) continue;  // no coarse level of width or height 0
        const Plane<std::int16_t> coarse = random_prior(w, h, ceil_half, dmin, dmax, seed++);
        expect_equal(&coarse, w, h, dmin, dmax, radius, ceil_half ? "ceil-half prior" : "floor-half prior");
        radius = (radius + 1) % 5;  // every radius 0..4 meets every kind of size
      }
    }
  }
}

TEST(CpuSearchRanges, EqualsReferenceForEveryRadius) {
  std::uint32_t seed = 500;
  for (auto [w, h] : {std::pair{127, 31}, std::pair{65, 4}, std::pair{2, 2}, std::pair{1, 9}})
    for (auto [dmin, dmax] : kRanges)
      for (bool ceil_half : {true, false}) {
        if (!ceil_half && w == 1) continue;  // no coarse level of width 0
        const Plane<std::int16_t> coarse = random_prior(w, h, ceil_half, dmin, dmax, seed++);
        for (int radius = 0; radius <= 4; ++radius)
          expect_equal(&coarse, w, h, dmin, dmax, radius, ceil_half ? "ceil-half prior" : "floor-half prior");
      }
}

TEST(CpuSearchRanges, AllInvalidAndLongRows) {
  Plane<std::int16_t> invalid(40, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 40; ++x) invalid.at(x, y) = kInvalid;
  expect_equal(&invalid, 80, 6, -3, 20, 2, "all invalid");
  // Coarse rows longer than one pass of 256 columns.
  const Plane<std::int16_t> coarse = random_disparity(600, 4, 5, -160, 480, 0.1, true);
  expect_equal(&coarse, 1199, 8, -10, 30, 3, "long rows");
}

TEST(CpuSearchRanges, KnownRanges) {
  // Coarse row 2, invalid, 5 (pixels) with radius 1 in [0, 10]:
  // x 0-1: neighbours 2, 2 (clamped), invalid -> [3, 5]; x 2-3: invalid centre -> [0, 10];
  // x 4-5: neighbours invalid, 5, 5 -> [9, 11] clipped to [9, 10].
  Plane<std::int16_t> coarse(3, 1);
  coarse.at(0, 0) = 16 * 2;
  coarse.at(1, 0) = kInvalid;
  coarse.at(2, 0) = 16 * 5;
  const int want_lo[6] = {3, 3, 0, 0, 9, 9}, want_hi[6] = {5, 5, 10, 10, 10, 10};
  for_each_target_and_threads([&](const std::string& label) {
    Ranges got(6, 2, 0);
    detail::cpu::search_ranges(&coarse, 0, 10, 1, got.lo, got.hi);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 6; ++x) {
        EXPECT_EQ(got.lo.at(x, y), want_lo[x]) << "x " << x << " " << label;
        EXPECT_EQ(got.hi.at(x, y), want_hi[x]) << "x " << x << " " << label;
      }
  });
}

}  // namespace
}  // namespace mctstereo::test
