// The confidence stage: known answers of the reference where the quotient margin x agreement /
// den is an exact integer or just below one, then cpu == reference bit for bit (the cpu stage's
// quotient is a multiply by a 32-bit reciprocal) with 1 and 2 threads, awkward sizes, every LR
// threshold (0 to 16), margins of the level itself and of coarser ones, with and without the
// right map, and disparities whose match lies outside the row.
#include <algorithm>
#include <random>
#include <string>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;
namespace reference = detail::reference;
namespace cpu = detail::cpu;

Plane<std::uint8_t> random_margin(int w, int h, int shift, std::uint32_t seed) {
  const int mw = ((w - 1) >> shift) + 1, mh = ((h - 1) >> shift) + 1;
  Plane<std::uint8_t> margin(mw, mh);
  std::mt19937 rng(seed);
  for (int y = 0; y < mh; ++y)
    for (int x = 0; x < mw; ++x) {
      const auto r = rng();
      margin.at(x, y) = static_cast<std::uint8_t>((r & 3) == 0 ? 255 : (r & 3) == 1 ? 0 : (r >> 8) & 0xFF);
    }
  return margin;
}

TEST(Confidence, KnownAnswers) {
  // One row: margin 255 everywhere; threshold 1 (den 32). The right map holds 16 x 2 at every
  // pixel, so the left pixel's value v at x meets 32 at x - 2 (inside from x = 2 on).
  const Plane<std::int16_t> left = make_map(8, 1, {32, 32, 32, 33, 47, 63, 64, kInvalid});
  const Plane<std::int16_t> right = make_map(8, 1, {32, 32, 32, 32, 32, 32, 32, 32});
  Plane<std::uint8_t> margin(8, 1), got(8, 1);
  for (int x = 0; x < 8; ++x) margin.at(x, 0) = 255;
  reference::confidence(margin, 0, left, &right, 1, got);
  // x = 0, 1: the match at x - 2 < 0 lies outside (0). x = 2: |32 - 32| = 0, 255 x 32 / 32.
  // x = 3: 255 x 31 / 32 = 247.03. x = 4 (v = 47, whole 3, meets x = 1): 255 x 17 / 32 = 135.5.
  // x = 5 (v = 63, whole 4): 255 x 1 / 32 = 7.97. x = 6 (v = 64, whole 4): |64 - 32| = 32 >= den.
  const int want[8] = {0, 0, 255, 247, 135, 7, 0, 0};
  for (int x = 0; x < 8; ++x) EXPECT_EQ(got.at(x, 0), want[x]) << "x = " << x;
  for_one_and_two_threads([&](const std::string& where) {
    Plane<std::uint8_t> fast(8, 1);
    cpu::confidence(margin, 0, left, &right, 1, fast);
    EXPECT_EQ(first_difference(got, fast), "") << where;
  });
}

TEST(Confidence, CpuEqualsReference) {
  std::uint32_t seed = 4100;
  int compared = 0;
  // Plain variables, not structured bindings: the lambda below names them (clang 14 cannot).
  for (const auto& size : awkward_sizes()) {
    const int w = size.first, h = size.second;
    for (const auto& range :
         {std::pair{0, 16 * 12}, std::pair{-16 * 40, 16 * 40}, std::pair{-16 * 1024, 16 * 2039 + 15}}) {
      const int lo = range.first, hi = range.second;
      // Right maps near the left one make the agreement term take every value in [0, den].
      const Plane<std::int16_t> left = random_disparity(w, h, ++seed, lo, hi, 0.15);
      Plane<std::int16_t> right = random_disparity(w, h, ++seed, lo, hi, 0.15);
      std::mt19937 rng(++seed);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const int v = left.at(x, y), xr = v == kInvalid ? -1 : x - ((v + 8) >> 4);
          if (xr >= 0 && xr < w && rng() % 3 != 0)
            right.at(xr, y) = static_cast<std::int16_t>(std::clamp(v + int(rng() % 600) - 300, -32767, 32767));
        }
      for (int shift : {0, 1, 2}) {
        const Plane<std::uint8_t> margin = random_margin(w, h, shift, ++seed);
        for (int threshold = 0; threshold <= 16; ++threshold) {
          const Plane<std::int16_t>* const right_maps[] = {&right, nullptr};
          for (const Plane<std::int16_t>* r : right_maps) {
            Plane<std::uint8_t> want(w, h), got(w, h);
            reference::confidence(margin, shift, left, r, threshold, want);
            for_one_and_two_threads([&](const std::string& where) {
              cpu::confidence(margin, shift, left, r, threshold, got);
              ASSERT_EQ(first_difference(want, got), "")
                  << w << "x" << h << " range " << lo << ".." << hi << " shift " << shift << " threshold " << threshold
                  << (r ? " with" : " without") << " the right map, on " << where;
            });
            ++compared;
          }
        }
      }
    }
  }
  EXPECT_EQ(compared, 15 * 3 * 3 * 17 * 2);
}

}  // namespace
}  // namespace mctstereo::test
