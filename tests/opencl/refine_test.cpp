// The opencl backend's refinement and output stages equal the reference bit for bit: median,
// LR check, fill, upscale, and the conversion to the caller's conventions. Device planes start
// filled with a marker, so that a kernel that read the padding after a row as data, or wrote
// into it, is caught.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "opencl/stages.hpp"
#include "opencl_test_util.hpp"
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;
using detail::opencl::DevicePlane;
using detail::opencl::Runtime;
namespace reference = detail::reference;
namespace ocl = detail::opencl;

constexpr std::int16_t I = kInvalid;

// ------------------------------------------------------------------------------------------
// Median.

TEST(OpenclRefine, MedianKnownAnswer) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // The reference's known answer (tests/cpu/refine_test.cpp): an impulse disappears, borders
  // repeat the edge, invalid pixels count as the smallest value.
  const auto src = make_map(5, 5, {10, 10, 10, 10, 10,  //
                                   10, 99, 10, 20, 20,  //
                                   10, 10, I, 20, 20,   //
                                   I, I, I, 20, 20,     //
                                   30, 30, I, 20, 20});
  const auto d_src = to_device(*rt, src);
  auto d_dst = marked_plane<std::int16_t>(*rt, 5, 5);
  ocl::median_filter(*rt, d_src, 3, d_dst);
  EXPECT_EQ(pixels(to_host(*rt, d_dst)), (std::vector<std::int16_t>{10, 10, 10, 10, 10,  //
                                                                    10, 10, 10, 10, 20,  //
                                                                    10, 10, 10, 20, 20,  //
                                                                    10, I, 10, 20, 20,   //
                                                                    30, I, 20, 20, 20}));
  EXPECT_EQ(padding_difference(*rt, d_dst), "");
}

TEST(OpenclRefine, MedianMatchesReference) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 100;
  for (auto [w, h] : awkward_sizes()) {
    for (const MapKind& kind : kMapKinds) {
      const auto src = random_disparity(w, h, ++seed, -400, 600, kind.invalid, kind.whole);
      const auto d_src = to_device(*rt, src);
      for (int k : {3, 5}) {
        Plane<std::int16_t> expected(w, h);
        reference::median_filter(src, k, expected);
        auto d_dst = marked_plane<std::int16_t>(*rt, w, h);
        ocl::median_filter(*rt, d_src, k, d_dst);
        ASSERT_EQ(first_difference(expected, to_host(*rt, d_dst)), "")
            << w << "x" << h << " k " << k << " invalid " << kind.invalid;
        ASSERT_EQ(padding_difference(*rt, d_dst), "") << w << "x" << h << " k " << k;
      }
    }
  }
}

TEST(OpenclRefine, MedianMatchesReferenceWithManyTies) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // Two values and invalid pixels: windows full of ties exercise every comparator of the networks.
  for (double invalid : {0.0, 0.3}) {
    const auto src = random_disparity(631, 479, invalid > 0 ? 7 : 8, 0, 1, invalid);
    const auto d_src = to_device(*rt, src);
    for (int k : {3, 5}) {
      Plane<std::int16_t> expected(631, 479);
      reference::median_filter(src, k, expected);
      auto d_dst = marked_plane<std::int16_t>(*rt, 631, 479);
      ocl::median_filter(*rt, d_src, k, d_dst);
      ASSERT_EQ(first_difference(expected, to_host(*rt, d_dst)), "") << "k " << k << " invalid " << invalid;
    }
  }
}

TEST(OpenclRefine, MedianRejectsOtherSizes) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  auto a = marked_plane<std::int16_t>(*rt, 8, 8), b = marked_plane<std::int16_t>(*rt, 8, 8);
  EXPECT_THROW(ocl::median_filter(*rt, a, 4, b), std::invalid_argument);
  auto small = marked_plane<std::int16_t>(*rt, 7, 8);
  EXPECT_THROW(ocl::median_filter(*rt, a, 3, small), std::invalid_argument);
}

// ------------------------------------------------------------------------------------------
// LR check.

TEST(OpenclRefine, GridPartnerMatchesReference) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 1900;
  for (auto [w, h] : awkward_sizes()) {
    for (const MapKind& kind : kMapKinds) {
      const auto right = random_disparity(w, h, ++seed, -400, 600, kind.invalid, kind.whole);
      const auto d_right = to_device(*rt, right);
      for (int k : {0, 3, 5}) {
        Plane<std::int16_t> expected(w, h);
        detail::MatchScratch none;
        reference::grid_partner(right, k, none, expected);
        auto d_dst = marked_plane<std::int16_t>(*rt, w, h);
        ocl::grid_partner(*rt, d_right, k, d_dst);
        ASSERT_EQ(first_difference(expected, to_host(*rt, d_dst)), "")
            << w << "x" << h << " k " << k << " invalid " << kind.invalid;
        ASSERT_EQ(padding_difference(*rt, d_dst), "") << w << "x" << h << " k " << k;
      }
    }
  }
}

TEST(OpenclRefine, GridPartnerRejectsOtherSizes) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  auto a = marked_plane<std::int16_t>(*rt, 8, 8), b = marked_plane<std::int16_t>(*rt, 8, 8);
  EXPECT_THROW(ocl::grid_partner(*rt, a, 1, b), std::invalid_argument);
  auto small = marked_plane<std::int16_t>(*rt, 7, 8);
  EXPECT_THROW(ocl::grid_partner(*rt, a, 3, small), std::invalid_argument);
}

TEST(OpenclRefine, LrCheckKnownAnswer) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // The reference's known answer: x = 4 disagrees by 24, x = 6 meets an invalid pixel, x = 7
  // points outside the image; the right reference looks the other way.
  const auto left = to_device(*rt, make_map(8, 1, {I, 16, 16, 32, 40, 24, 8, 200}));
  const auto right = to_device(*rt, make_map(8, 1, {16, 16, 32, 24, 48, I, 40, 16}));
  auto dst = marked_plane<std::int16_t>(*rt, 8, 1);
  ocl::lr_check(*rt, left, right, -1, 16, dst);
  EXPECT_EQ(pixels(to_host(*rt, dst)), (std::vector<std::int16_t>{I, 16, 16, 32, I, 24, I, I}));
  ocl::lr_check(*rt, right, left, +1, 16, dst);
  EXPECT_EQ(pixels(to_host(*rt, dst)), (std::vector<std::int16_t>{16, 16, 32, 24, I, I, I, I}));
  EXPECT_EQ(padding_difference(*rt, dst), "");
}

TEST(OpenclRefine, LrCheckRejectsPartnersOutsideTheImage) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // Every pixel 1 px and every partner agreeing, padding included: only the pixel whose partner
  // lies one past the image border (x = 0 looking left, x = w - 1 looking right) is rejected.
  for (int w : {1, 20, 33}) {
    Plane<std::int16_t> map(w, 2);
    for (int y = 0; y < 2; ++y) std::fill(map.row(y), map.row(y) + w, std::int16_t{16});
    DevicePlane<std::int16_t> d_map;
    d_map.reset(*rt, w, 2);
    const std::vector<std::int16_t> all_16(d_map.bytes() / 2, 16);
    rt->queue().enqueueWriteBuffer(d_map.buffer, CL_TRUE, 0, d_map.bytes(), all_16.data());
    auto d_dst = marked_plane<std::int16_t>(*rt, w, 2);
    for (int dir : {-1, +1}) {
      ocl::lr_check(*rt, d_map, d_map, dir, 0, d_dst);
      const auto dst = to_host(*rt, d_dst);
      for (int y = 0; y < 2; ++y)
        for (int x = 0; x < w; ++x)
          ASSERT_EQ(dst.at(x, y), x == (dir < 0 ? 0 : w - 1) ? I : 16) << "(" << x << ", " << y << ") dir " << dir;
    }
  }
}

TEST(OpenclRefine, LrCheckMatchesReference) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 200;
  for (auto [w, h] : awkward_sizes()) {
    for (const MapKind& kind : kMapKinds) {
      const auto [src, other, narrow, narrow_other] = lr_check_maps(w, h, seed, kind);
      const auto d_src = to_device(*rt, src), d_other = to_device(*rt, other);
      const auto d_narrow = to_device(*rt, narrow), d_narrow_other = to_device(*rt, narrow_other);
      auto d_dst = marked_plane<std::int16_t>(*rt, w, h);
      for (int dir : {-1, +1}) {
        for (int threshold : {0, 16, 32}) {
          const std::pair<const Plane<std::int16_t>*, const DevicePlane<std::int16_t>*> pairs[2][2] = {
              {{&src, &d_src}, {&other, &d_other}}, {{&narrow, &d_narrow}, {&narrow_other, &d_narrow_other}}};
          for (const auto& [a, b] : pairs) {
            Plane<std::int16_t> expected(w, h);
            reference::lr_check(*a.first, *b.first, dir, threshold, expected);
            ocl::lr_check(*rt, *a.second, *b.second, dir, threshold, d_dst);
            ASSERT_EQ(first_difference(expected, to_host(*rt, d_dst)), "")
                << w << "x" << h << " dir " << dir << " threshold " << threshold << " invalid " << kind.invalid;
          }
        }
      }
      ASSERT_EQ(padding_difference(*rt, d_dst), "") << w << "x" << h;
    }
  }
}

TEST(OpenclRefine, LrCheckMatchesReferenceOnSmoothMaps) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 700;
  auto sizes = awkward_sizes();
  sizes.push_back({300, 2});
  for (auto [w, h] : sizes) {
    for (auto [base, step] : kLrCheckMapShapes) {
      const auto a = smooth_disparity(w, h, ++seed, base, step, 9);
      const auto b = smooth_disparity(w, h, ++seed, base, step, 9);
      const auto d_a = to_device(*rt, a), d_b = to_device(*rt, b);
      auto d_dst = marked_plane<std::int16_t>(*rt, w, h);
      for (int dir : {-1, +1}) {
        for (int threshold : {0, 16, 32}) {
          Plane<std::int16_t> expected(w, h);
          reference::lr_check(a, b, dir, threshold, expected);
          if (w * h > 1000 && base == 16 * 3) {
            const int kept = w * h - count_invalid(expected);
            ASSERT_GT(kept, threshold == 32 ? w * h / 10 : 0) << "a vacuous case, threshold " << threshold;
          }
          ocl::lr_check(*rt, d_a, d_b, dir, threshold, d_dst);
          ASSERT_EQ(first_difference(expected, to_host(*rt, d_dst)), "")
              << w << "x" << h << " base " << base << " dir " << dir << " threshold " << threshold;
        }
      }
    }
  }
}

// ------------------------------------------------------------------------------------------
// Fill.

TEST(OpenclRefine, FillKnownAnswers) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  for (const FillCase& c : fill_known_answers()) {
    Plane<std::int16_t> host(static_cast<int>(c.in.size()), 1);
    std::copy(c.in.begin(), c.in.end(), host.row(0));
    auto d = to_device(*rt, host);
    ocl::fill_invalid(*rt, d, c.mode);
    EXPECT_EQ(pixels(to_host(*rt, d)), c.out) << "mode " << static_cast<int>(c.mode) << ", case starting " << c.in[0];
    EXPECT_EQ(padding_difference(*rt, d), "");
  }
}

TEST(OpenclRefine, FillInvalidMatchesReference) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 400;
  auto sizes = awkward_sizes();
  sizes.push_back({200, 3});  // runs longer than a 16-pixel chunk at 85 % invalid
  for (auto [w, h] : sizes) {
    for (double invalid : {0.0, 0.1, 0.6, 0.85, 1.0}) {
      const auto map = random_disparity(w, h, ++seed, -400, 600, invalid, invalid == 0.6);
      for (FillMode mode : {FillMode::None, FillMode::Nearest, FillMode::NearestLower}) {
        Plane<std::int16_t> expected(w, h);
        for (int y = 0; y < h; ++y) std::copy(map.row(y), map.row(y) + w, expected.row(y));
        reference::fill_invalid(expected, mode);
        auto d = to_device(*rt, map);
        ocl::fill_invalid(*rt, d, mode);
        ASSERT_EQ(first_difference(expected, to_host(*rt, d)), "")
            << w << "x" << h << " mode " << static_cast<int>(mode) << " invalid " << invalid;
        ASSERT_EQ(padding_difference(*rt, d), "") << w << "x" << h;
      }
    }
  }
}

// ------------------------------------------------------------------------------------------
// Upscale.

TEST(OpenclRefine, UpscaleKnownValues) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // Source 40 x 1: 16 * 3, invalid, then 16 * x. Factor 2 into 79 x 2 (one column cut), clamped
  // to [0, 16 * 50].
  Plane<std::int16_t> src(40, 1);
  for (int x = 0; x < 40; ++x) src.at(x, 0) = static_cast<std::int16_t>(16 * x);
  src.at(0, 0) = 16 * 3;
  src.at(1, 0) = kInvalid;
  const auto d_src = to_device(*rt, src);
  auto d_dst = marked_plane<std::int16_t>(*rt, 79, 2);
  ocl::upscale(*rt, d_src, 2, 0, 16 * 50, d_dst);
  const auto dst = to_host(*rt, d_dst);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 79; ++x) {
      const int sx = x / 2;
      const int want = sx == 0 ? 16 * 6 : sx == 1 ? kInvalid : std::min(32 * sx, 16 * 50);
      ASSERT_EQ(dst.at(x, y), want) << "(" << x << ", " << y << ")";
    }
  EXPECT_EQ(padding_difference(*rt, d_dst), "");
}

TEST(OpenclRefine, UpscaleMatchesReference) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 3;
  for (int factor : {2, 4, 1, 3}) {
    for (auto [w, h] : awkward_sizes()) {
      // The destination is the awkward size, mostly not a multiple of the factor, and also the
      // whole factor x source.
      const int sw = (w + factor - 1) / factor, sh = (h + factor - 1) / factor;
      // Values beyond [lo, hi] after scaling on both sides, and products beyond int16.
      const Plane<std::int16_t> src = random_disparity(sw, sh, seed++, -16 * 40, 16 * 1800, 0.15);
      const auto d_src = to_device(*rt, src);
      for (auto [dw, dh] : {std::pair{w, h}, {sw * factor, sh * factor}}) {
        for (auto [lo_q4, hi_q4] : {std::pair{-16 * 50, 16 * 2000}, {0, 16 * 60}}) {
          Plane<std::int16_t> expected(dw, dh);
          reference::upscale(src, factor, lo_q4, hi_q4, expected);
          auto d_dst = marked_plane<std::int16_t>(*rt, dw, dh);
          ocl::upscale(*rt, d_src, factor, lo_q4, hi_q4, d_dst);
          ASSERT_EQ(first_difference(expected, to_host(*rt, d_dst)), "")
              << "factor " << factor << " " << sw << "x" << sh << " -> " << dw << "x" << dh << " clamp " << lo_q4
              << ".." << hi_q4;
          ASSERT_EQ(padding_difference(*rt, d_dst), "") << "factor " << factor << " " << dw << "x" << dh;
        }
      }
    }
  }
}

TEST(OpenclRefine, UpscaleRejectsADestinationBeyondTheSource) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  auto src = marked_plane<std::int16_t>(*rt, 10, 5);
  auto big = marked_plane<std::int16_t>(*rt, 21, 10);
  EXPECT_THROW(ocl::upscale(*rt, src, 2, 0, 100, big), std::invalid_argument);
  EXPECT_THROW(ocl::upscale(*rt, src, 0, 0, 100, big), std::invalid_argument);
}

// ------------------------------------------------------------------------------------------
// Output conventions.

TEST(OpenclRefine, ToOutputMatchesTheMatcherConventions) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 900;
  auto sizes = awkward_sizes();
  for (auto [w, h] : sizes) {
    // The whole int16 range: the float of every value is exact.
    const auto src = random_disparity(w, h, ++seed, -32767, 32767, 0.2);
    const auto d_src = to_device(*rt, src);
    for (const std::int16_t invalid_q4 : {std::int16_t{-16}, std::int16_t{16 * 7}}) {
      for (const bool with_float : {false, true}) {
        auto d_q4 = marked_plane<std::int16_t>(*rt, w, h);
        auto d_float = marked_plane<float>(*rt, w, h);
        ocl::to_output(*rt, d_src, invalid_q4, d_q4, with_float ? &d_float : nullptr);
        const auto q4 = to_host(*rt, d_q4);
        const auto f = to_host(*rt, d_float);
        for (int y = 0; y < h; ++y) {
          for (int x = 0; x < w; ++x) {
            const std::int16_t v = src.at(x, y);
            ASSERT_EQ(q4.at(x, y), v == kInvalid ? invalid_q4 : v) << "(" << x << ", " << y << ") " << w << "x" << h;
            // As Matcher writes it, compared bit for bit (NaN included).
            const float want = !with_float ? marker<float>() : v == kInvalid ? NAN : static_cast<float>(v) / 16;
            std::uint32_t got_bits, want_bits;
            std::memcpy(&got_bits, &f.at(x, y), 4);
            std::memcpy(&want_bits, &want, 4);
            ASSERT_EQ(got_bits, want_bits) << "(" << x << ", " << y << ") " << w << "x" << h << " value " << v
                                           << (with_float ? "" : " (no float map asked for)");
            if (with_float) {
              ASSERT_EQ(std::isnan(f.at(x, y)), v == kInvalid);
            }
          }
        }
        ASSERT_EQ(padding_difference(*rt, d_q4), "") << w << "x" << h;
        ASSERT_EQ(padding_difference(*rt, d_float), "") << w << "x" << h;
      }
    }
  }
}

TEST(OpenclRefine, StagesRecordTheirLabels) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const auto src = to_device(*rt, random_disparity(40, 6, 1, 0, 300, 0.2));
  auto a = marked_plane<std::int16_t>(*rt, 40, 6), c = marked_plane<std::int16_t>(*rt, 40, 6);
  auto b = marked_plane<std::int16_t>(*rt, 80, 12);
  auto q = marked_plane<std::int16_t>(*rt, 80, 12);
  auto f = marked_plane<float>(*rt, 80, 12);
  rt->reset_times();
  ocl::median_filter(*rt, src, 3, a);
  ocl::lr_check(*rt, a, src, -1, 16, c);
  ocl::fill_invalid(*rt, c, FillMode::Nearest);
  ocl::upscale(*rt, c, 2, 0, 600, b);
  ocl::to_output(*rt, b, -16, q, &f);
  std::vector<std::string> labels;
  for (const auto& [label, ms] : rt->kernel_times()) labels.push_back(label);
  EXPECT_EQ(labels, (std::vector<std::string>{"median", "lr_check", "fill", "upscale", "output"}));
}

}  // namespace
}  // namespace mctstereo::test
