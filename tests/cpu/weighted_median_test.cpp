// The colour-weighted median: known answers of the reference (and the cpu stage on the same
// cases), then cpu == reference bit for bit on seeded random maps and images.
#include <omp.h>

#include <array>
#include <random>
#include <string>
#include <vector>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::ColourPlanes;
using detail::kInvalid;
using detail::WeightedMedianConfig;
namespace reference = detail::reference;
namespace cpu = detail::cpu;

constexpr std::int16_t I = kInvalid;

// Three channel planes and their view for the stage.
struct Colour {
  std::array<Plane<std::uint8_t>, 3> plane;
  ColourPlanes view(int channels) const {
    ColourPlanes c;
    c.channels = channels;
    for (int k = 0; k < 3; ++k) c.plane[k] = &plane[channels == 3 ? k : 0];
    return c;
  }
};

// w x h pixels of (r, g, b) triplets, row after row.
Colour make_colour(int w, int h, std::initializer_list<std::array<int, 3>> rgb) {
  Colour c;
  for (auto& p : c.plane) p.reset(w, h);
  auto it = rgb.begin();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x, ++it)
      for (int k = 0; k < 3; ++k) c.plane[k].at(x, y) = static_cast<std::uint8_t>((*it)[k]);
  return c;
}

Colour uniform_colour(int w, int h, int value) {
  Colour c;
  for (auto& p : c.plane) {
    p.reset(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) p.at(x, y) = static_cast<std::uint8_t>(value);
  }
  return c;
}

WeightedMedianConfig config(int radius, int step, int sigma) {
  WeightedMedianConfig c;
  c.radius = radius;
  c.step = step;
  c.lut = detail::weighted_median_lut(sigma);
  return c;
}

// Runs the reference and the cpu stage (every target, 1 and 2 threads) on one case and checks
// both against the expected pixels.
void expect_both(const Plane<std::int16_t>& src, const ColourPlanes& colour, const WeightedMedianConfig& c,
                 const std::vector<std::int16_t>& expected, const std::string& what) {
  Plane<std::int16_t> dst(src.width(), src.height());
  reference::weighted_median(src, colour, c, dst);
  EXPECT_EQ(pixels(dst), expected) << what << " (reference)";
  for_each_target_and_threads([&](const std::string& where) {
    Plane<std::int16_t> out(src.width(), src.height());
    cpu::weighted_median(src, colour, c, out);
    EXPECT_EQ(pixels(out), expected) << what << " (cpu on " << where << ")";
  });
}

TEST(WeightedMedian, TableValues) {
  const auto lut = detail::weighted_median_lut(10);
  EXPECT_EQ(lut[0], 64);
  EXPECT_EQ(lut[10], 24);  // 64 / e = 23.54
  EXPECT_EQ(lut[48], 1);   // 0.53
  EXPECT_EQ(lut[49], 0);   // 0.48
  EXPECT_EQ(lut[255], 0);
  const auto wide = detail::weighted_median_lut(255);
  EXPECT_EQ(wide[0], 64);
  EXPECT_EQ(wide[255], 24);
  const auto narrow = detail::weighted_median_lut(1);
  EXPECT_EQ(narrow[1], 24);
  EXPECT_EQ(narrow[5], 0);  // 0.43
  EXPECT_EQ(narrow[4], 1);  // 1.17
}

TEST(WeightedMedian, TiesGoToTheSmallerDisparity) {
  // Pixel 1 is invalid; its window (radius 1, one row: each column three times) holds d = 1 and
  // d = 2 with equal weights: S(1) = ceil(total / 2) exactly, so 1 wins and the pixel becomes 16.
  const auto src = make_map(3, 1, {16, I, 32});
  const Colour colour = uniform_colour(3, 1, 100);
  expect_both(src, colour.view(1), config(1, 1, 10), {16, 16, 32}, "tie");
}

TEST(WeightedMedian, SubpixelStaysWhereTheMedianIsTheOwnDisparity) {
  // 20 and 23 are whole 1, 24 (1.5 px) is whole 2, 56 whole 4. Pixel 1 (d 1 4 1) moves to
  // 16 x 1 and pixel 2 (d 4 1 2) to 16 x 2; pixels 0, 3 and 4 find their own whole disparity and
  // keep their Q4 values (24, not 32).
  const auto src = make_map(5, 1, {20, 56, 20, 24, 24});
  const Colour colour = uniform_colour(5, 1, 7);
  expect_both(src, colour.view(1), config(1, 1, 10), {20, 16, 32, 24, 24}, "sub-pixel");
  const auto src2 = make_map(3, 1, {20, 56, 23});
  expect_both(src2, colour.view(1), config(1, 1, 10), {20, 16, 23}, "moved");
}

TEST(WeightedMedian, ColourDecidesWhichNeighboursCount) {
  // Pixel 2 of d = 1 1 2 3 3 with radius 2: in gray all weigh 64 and the median is its own 2; in
  // colour the last two differ in blue by 180 (weight 0), so d = 1 has 128 of 192 and wins. The
  // first channel alone (the gray view here) sees no difference.
  const auto src = make_map(5, 1, {16, 16, 32, 48, 48});
  const Colour colour =
      make_colour(5, 1, {{50, 60, 70}, {50, 60, 70}, {50, 60, 70}, {50, 60, 250}, {50, 60, 250}});
  Plane<std::int16_t> dst(5, 1);
  reference::weighted_median(src, colour.view(3), config(2, 1, 10), dst);
  EXPECT_EQ(dst.at(2, 0), 16);
  reference::weighted_median(src, colour.view(1), config(2, 1, 10), dst);
  EXPECT_EQ(dst.at(2, 0), 32);
  expect_both(src, colour.view(3), config(2, 1, 10), {16, 16, 16, 48, 48}, "colour");
  expect_both(src, colour.view(1), config(2, 1, 10), {16, 16, 32, 48, 48}, "first channel");
  // RGB and BGR give the same weights (the largest channel difference).
  const Colour bgr =
      make_colour(5, 1, {{70, 60, 50}, {70, 60, 50}, {70, 60, 50}, {250, 60, 50}, {250, 60, 50}});
  expect_both(src, bgr.view(3), config(2, 1, 10), {16, 16, 16, 48, 48}, "bgr");
}

TEST(WeightedMedian, InvalidSamplesAndZeroTotals) {
  // All invalid: nothing to weigh, the map stays. Pixel 1 sees only samples of weight 0 (colour
  // 255 away) and stays invalid; pixels 0 and 2 see themselves.
  expect_both(make_map(3, 1, {I, I, I}), uniform_colour(3, 1, 9).view(1), config(1, 1, 10), {I, I, I}, "all invalid");
  const Colour colour = make_colour(3, 1, {{0, 0, 0}, {255, 255, 255}, {0, 0, 0}});
  expect_both(make_map(3, 1, {16, I, 48}), colour.view(3), config(1, 1, 10), {16, I, 48}, "weight 0");
  // Invalid samples weigh 0: three invalid neighbours (which as the smallest values would pull a
  // plain median down) leave pixel 1 at its own value.
  expect_both(make_map(4, 1, {I, 64, 64, I}), uniform_colour(4, 1, 9).view(1), config(1, 1, 10), {64, 64, 64, 64},
              "invalid neighbours");
}

TEST(WeightedMedian, ClampedBorders) {
  // 2 x 2, radius 1: clamping repeats the corner pixels, so (1, 1) sees d = 1 three times, d = 2
  // twice and d = 3 four times and takes 2 (the in-image pixels alone would give 1).
  const auto src = make_map(2, 2, {16, 16, 32, 48});
  expect_both(src, uniform_colour(2, 2, 50).view(1), config(1, 1, 10), {16, 16, 32, 32}, "2x2");
  expect_both(make_map(1, 1, {40}), uniform_colour(1, 1, 50).view(1), config(9, 3, 10), {40}, "1x1");
}

TEST(WeightedMedian, OffsetsAreMultiplesOfTheStep) {
  // Radius 4, step 3: offsets -3, 0, 3 (the multiples of 3 in [-4, 4]). On one row of 7 pixels,
  // pixel 3 samples columns 0, 3, 6: d = 5, 1, 5 -> 5; columns 1, 2, 4, 5 (d = 9) are not read.
  const auto src = make_map(7, 1, {80, 144, 144, 16, 144, 144, 80});
  Plane<std::int16_t> dst(7, 1);
  reference::weighted_median(src, uniform_colour(7, 1, 3).view(1), config(4, 3, 10), dst);
  EXPECT_EQ(dst.at(3, 0), 80);
}

// ------------------------------------------------------------------------------------------
// cpu == reference.

Colour random_colour(int w, int h, std::uint32_t seed, int kind) {
  Colour c;
  for (int k = 0; k < 3; ++k) {
    if (kind == 0) c.plane[k] = random_texture(w, h, seed + k);
    else if (kind == 1) c.plane[k] = few_levels_image(w, h, seed + k);
    else c.plane[k] = random_image(w, h, seed + k);
  }
  return c;
}

struct RangeCase {
  int lo_q4, hi_q4;
};

TEST(WeightedMedianCpu, MatchesReference) {
  const std::vector<std::pair<int, int>> sizes = {{1, 1},  {1, 9},  {7, 1},  {7, 2},  {33, 1}, {33, 2}, {97, 2},
                                                  {97, 5}, {16, 3}, {64, 4}, {65, 7}, {130, 3}, {41, 23}};
  // Disparity ranges (Q4): around zero, negative down to -1024 px, beyond 256 px, up to 2039 px.
  const RangeCase ranges[] = {{-160, 640}, {-16 * 1024, -16 * 1000}, {16 * 250, 16 * 300}, {16 * 2000, 16 * 2039 + 7},
                              {-16 * 3, 16 * 3}};
  struct ConfigCase {
    int radius, step, sigma;
  };
  const ConfigCase configs[] = {{9, 3, 10}, {1, 1, 10}, {4, 3, 255}, {15, 5, 1}, {6, 2, 30}};
  std::uint32_t seed = 7000;
  for (const auto& w_h : sizes) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (const MapKind& kind : kMapKinds) {
      for (const RangeCase& range : ranges) {
        const auto src = random_disparity(w, h, ++seed, range.lo_q4, range.hi_q4, kind.invalid, kind.whole);
        ++seed;
        const Colour colour = random_colour(w, h, seed, static_cast<int>(seed % 3));
        for (const ConfigCase& cc : configs) {
          const WeightedMedianConfig c = config(cc.radius, cc.step, cc.sigma);
          for (int channels : {1, 3}) {
            Plane<std::int16_t> expected(w, h), actual(w, h);
            reference::weighted_median(src, colour.view(channels), c, expected);
            for_each_target_and_threads([&](const std::string& where) {
              cpu::weighted_median(src, colour.view(channels), c, actual);
              ASSERT_EQ(first_difference(expected, actual), "")
                  << w << "x" << h << " invalid " << kind.invalid << " range " << range.lo_q4 << ".." << range.hi_q4
                  << " radius " << cc.radius << " step " << cc.step << " sigma " << cc.sigma << " channels "
                  << channels << " on " << where;
            });
          }
        }
      }
    }
  }
}

TEST(WeightedMedianCpu, MatchesReferenceOnSmoothMapsAndWideWindows) {
  // Maps like real ones (steps, sub-pixel noise across the rounding point), smooth colour, every
  // sample of a 15-radius window (961 samples).
  std::uint32_t seed = 9000;
  for (const auto& w_h : std::vector<std::pair<int, int>>{{97, 31}, {200, 9}, {33, 40}}) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    const auto src = smooth_disparity(w, h, ++seed, 16 * 20, 9, 12);
    const Colour colour = random_colour(w, h, ++seed, 0);
    for (const auto& radius_step : std::vector<std::pair<int, int>>{{15, 1}, {9, 3}, {2, 2}}) {
      const auto radius = radius_step.first;
      const auto step = radius_step.second;
      Plane<std::int16_t> expected(w, h), actual(w, h);
      reference::weighted_median(src, colour.view(3), config(radius, step, 10), expected);
      for_each_target_and_threads([&](const std::string& where) {
        cpu::weighted_median(src, colour.view(3), config(radius, step, 10), actual);
        ASSERT_EQ(first_difference(expected, actual), "") << w << "x" << h << " radius " << radius << " on " << where;
      });
    }
  }
}

TEST(WeightedMedianCpu, ScalarFormsMatchReference) {
  std::uint32_t seed = 9500;
  for (const auto& w_h : std::vector<std::pair<int, int>>{{1, 1}, {33, 2}, {97, 13}}) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    const auto src = random_disparity(w, h, ++seed, -16 * 40, 16 * 300, 0.2, false);
    const Colour colour = random_colour(w, h, ++seed, 0);
    Plane<std::int16_t> expected(w, h), actual(w, h);
    reference::weighted_median(src, colour.view(3), config(9, 3, 10), expected);
    for (auto method : {cpu::WeightedMedianMethod::Histogram, cpu::WeightedMedianMethod::Sort}) {
      cpu::weighted_median_scalar(src, colour.view(3), config(9, 3, 10), method, actual);
      EXPECT_EQ(first_difference(expected, actual), "") << w << "x" << h << " method " << static_cast<int>(method);
    }
  }
}

TEST(SplitChannelsCpu, MatchesReference) {
  std::uint32_t seed = 9700;
  for (const auto& w_h : awkward_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (PixelFormat format : {PixelFormat::Gray8, PixelFormat::Rgb8, PixelFormat::Bgr8}) {
      const RandomInput input(w, h, format, 5, ++seed);
      std::array<Plane<std::uint8_t>, 3> expected, actual;
      for (int c = 0; c < 3; ++c) expected[c].reset(w, h), actual[c].reset(w, h);
      reference::split_channels(input.view, expected);
      const int channels = bytes_per_pixel(format);
      for (int c = 0; c < channels; ++c)
        EXPECT_EQ(expected[c].at(w - 1, h - 1), input.bytes[(h - 1) * input.view.stride + channels * (w - 1) + c]);
      for_each_target_and_threads([&](const std::string& where) {
        cpu::split_channels(input.view, actual);
        for (int c = 0; c < channels; ++c)
          ASSERT_EQ(first_difference(expected[c], actual[c]), "")
              << w << "x" << h << " " << format_name(format) << " channel " << c << " on " << where;
      });
    }
  }
}

}  // namespace
}  // namespace mctstereo::test
