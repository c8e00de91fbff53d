// cpu::to_gray and cpu::pyramid_down equal the reference bit for bit, on every SIMD target and with
// 1 and 2 threads.
#include <omp.h>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

TEST(CpuGray, EqualsReferenceForEveryFormatSizeAndStride) {
  std::uint32_t seed = 1;
  for (const auto& w_h : awkward_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (PixelFormat format : {PixelFormat::Gray8, PixelFormat::Rgb8, PixelFormat::Bgr8}) {
      for (int extra : {0, 13}) {
        const RandomInput input(w, h, format, extra, seed++);
        Plane<std::uint8_t> expected(w, h);
        detail::reference::to_gray(input.view, expected);
        for_each_target_and_threads([&](const std::string& label) {
          Plane<std::uint8_t> got(w, h, 5);  // a padded destination too
          detail::cpu::to_gray(input.view, got);
          EXPECT_EQ(first_difference(got, expected), "")
              << w << "x" << h << " " << format_name(format) << " stride +" << extra << " " << label;
        });
      }
    }
  }
}

TEST(CpuGray, KnownLumaValues) {
  // 40 pixels, so that the vector path runs on every target.
  const KnownLuma known = known_luma_row();
  const std::vector<std::uint8_t>& rgb = known.rgb;
  const std::vector<int>& want = known.luma;
  const ImageView view{rgb.data(), 40, 1, static_cast<std::ptrdiff_t>(rgb.size()), PixelFormat::Rgb8};
  for_each_target_and_threads([&](const std::string& label) {
    Plane<std::uint8_t> out(40, 1);
    detail::cpu::to_gray(view, out);
    for (int x = 0; x < 40; ++x) ASSERT_EQ(out.at(x, 0), want[x]) << "x = " << x << " " << label;
  });
}

TEST(CpuPyramid, EqualsReferenceOnOddAndEvenSizes) {
  std::uint32_t seed = 100;
  for (const auto& w_h : pyramid_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (int pad : {0, 7}) {
      const Plane<std::uint8_t> src = random_image(w, h, seed++, pad);
      Plane<std::uint8_t> expected((w + 1) / 2, (h + 1) / 2);
      detail::reference::pyramid_down(src, expected);
      for_each_target_and_threads([&](const std::string& label) {
        Plane<std::uint8_t> got((w + 1) / 2, (h + 1) / 2);
        detail::cpu::pyramid_down(src, got);
        EXPECT_EQ(first_difference(got, expected), "") << w << "x" << h << " pad " << pad << " " << label;
      });
    }
  }
}

TEST(CpuPyramid, ImpulseGivesTheBinomialWeights) {
  for_each_target_and_threads([&](const std::string& label) {
    Plane<std::uint8_t> src(99, 9);
    src.at(50, 4) = 255;
    Plane<std::uint8_t> dst(50, 5);
    detail::cpu::pyramid_down(src, dst);
    EXPECT_EQ(dst.at(25, 2), (36 * 255 + 128) >> 8) << label;
    EXPECT_EQ(dst.at(24, 2), (6 * 255 + 128) >> 8) << label;
    EXPECT_EQ(dst.at(26, 1), (1 * 255 + 128) >> 8) << label;
    EXPECT_EQ(dst.at(23, 2), 0) << label;
  });
}

}  // namespace
}  // namespace mctstereo::test
