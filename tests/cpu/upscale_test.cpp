// cpu::upscale equals the reference bit for bit, on every SIMD target and with 1 and 2 threads.
#include <omp.h>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;

TEST(CpuUpscale, EqualsReferenceAtAwkwardSizes) {
  std::uint32_t seed = 3;
  for (int factor : {2, 4, 1, 3}) {
    for (const auto& w_h : awkward_sizes()) {
      const auto w = w_h.first;
      const auto h = w_h.second;
      // The destination is the awkward size, mostly not a multiple of the factor.
      const int sw = (w + factor - 1) / factor, sh = (h + factor - 1) / factor;
      // Values beyond [lo, hi] after scaling on both sides, and products beyond int16.
      const Plane<std::int16_t> src = random_disparity(sw, sh, seed++, -16 * 40, 16 * 1800, 0.15);
      const int lo_q4 = -16 * 50, hi_q4 = 16 * 2000;
      Plane<std::int16_t> expected(w, h);
      detail::reference::upscale(src, factor, lo_q4, hi_q4, expected);
      for_each_target_and_threads([&](const std::string& label) {
        Plane<std::int16_t> got(w, h, 2);
        detail::cpu::upscale(src, factor, lo_q4, hi_q4, got);
        EXPECT_EQ(first_difference(got, expected), "") << "factor " << factor << " " << w << "x" << h << " " << label;
      });
    }
  }
}

TEST(CpuUpscale, KnownValues) {
  // Source 40 x 1: 16 * 3, invalid, then 16 * x. Factor 2 into 79 x 2 (one column cut), clamped
  // to [0, 16 * 50].
  Plane<std::int16_t> src(40, 1);
  for (int x = 0; x < 40; ++x) src.at(x, 0) = static_cast<std::int16_t>(16 * x);
  src.at(0, 0) = 16 * 3;
  src.at(1, 0) = kInvalid;
  for_each_target_and_threads([&](const std::string& label) {
    Plane<std::int16_t> dst(79, 2);
    detail::cpu::upscale(src, 2, 0, 16 * 50, dst);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 79; ++x) {
        const int sx = x / 2;
        const int want = sx == 0 ? 16 * 6 : sx == 1 ? kInvalid : std::min(32 * sx, 16 * 50);
        ASSERT_EQ(dst.at(x, y), want) << "(" << x << ", " << y << ") " << label;
      }
  });
}

}  // namespace
}  // namespace mctstereo::test
