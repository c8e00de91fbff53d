// cpu::to_gray and cpu::pyramid_down equal the reference bit for bit, on every SIMD target and with
// 1 and 2 threads.
#include <omp.h>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

// Runs fn on every SIMD target with 1 and 2 OpenMP threads; fn gets a label for failure messages.
// An interleaved input image of seeded random bytes whose rows are `extra` bytes longer than the
// pixels. The buffer ends right after the last pixel, as a caller's image may.
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

const char* format_name(PixelFormat f) {
  return f == PixelFormat::Gray8 ? "gray8" : f == PixelFormat::Rgb8 ? "rgb8" : "bgr8";
}

TEST(CpuGray, EqualsReferenceForEveryFormatSizeAndStride) {
  std::uint32_t seed = 1;
  for (auto [w, h] : awkward_sizes()) {
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
  // (77 R + 150 G + 29 B + 128) >> 8 for 40 pixels, so that the vector path runs on every target.
  std::vector<std::uint8_t> rgb;
  std::vector<int> want;
  for (int i = 0; i < 40; ++i) {
    const int r = (i * 37) % 256, g = (i * 91 + 7) % 256, b = 255 - (i * 13) % 256;
    rgb.insert(rgb.end(), {static_cast<std::uint8_t>(r), static_cast<std::uint8_t>(g), static_cast<std::uint8_t>(b)});
    want.push_back((77 * r + 150 * g + 29 * b + 128) >> 8);
  }
  const ImageView view{rgb.data(), 40, 1, static_cast<std::ptrdiff_t>(rgb.size()), PixelFormat::Rgb8};
  for_each_target_and_threads([&](const std::string& label) {
    Plane<std::uint8_t> out(40, 1);
    detail::cpu::to_gray(view, out);
    for (int x = 0; x < 40; ++x) ASSERT_EQ(out.at(x, 0), want[x]) << "x = " << x << " " << label;
  });
}

std::vector<std::pair<int, int>> pyramid_sizes() {
  std::vector<std::pair<int, int>> sizes = awkward_sizes();
  // 1 x N and N x 1 of both parities, and rows longer than one pass of 512 output columns.
  sizes.insert(sizes.end(), {{1, 1}, {1, 7}, {7, 1}, {2, 1}, {1, 2}, {3, 3}, {4, 5}, {1025, 3}, {1100, 4}});
  return sizes;
}

TEST(CpuPyramid, EqualsReferenceOnOddAndEvenSizes) {
  std::uint32_t seed = 100;
  for (auto [w, h] : pyramid_sizes()) {
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
