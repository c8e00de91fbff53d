// The opencl colour-weighted median and channel split equal the cpu stages (themselves equal to
// the reference, tests/cpu/weighted_median_test.cpp) bit for bit; device planes start filled with
// a marker so that a write into the padding is caught.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "opencl/stages.hpp"
#include "opencl_test_util.hpp"
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;
using detail::opencl::DeviceColour;
using detail::opencl::DeviceImage;
using detail::opencl::DevicePlane;
namespace ocl = detail::opencl;
namespace cpu = detail::cpu;

constexpr std::int16_t I = kInvalid;

detail::WeightedMedianConfig config(int radius, int step, int sigma) {
  detail::WeightedMedianConfig c;
  c.radius = radius;
  c.step = step;
  c.lut = detail::weighted_median_lut(sigma);
  return c;
}

struct Colour {
  std::array<Plane<std::uint8_t>, 3> host;
  std::array<DevicePlane<std::uint8_t>, 3> device;
  detail::ColourPlanes host_view(int channels) const {
    detail::ColourPlanes c;
    c.channels = channels;
    for (int k = 0; k < 3; ++k) c.plane[k] = &host[channels == 3 ? k : 0];
    return c;
  }
  DeviceColour device_view(int channels) const {
    DeviceColour c;
    c.channels = channels;
    for (int k = 0; k < 3; ++k) c.plane[k] = &device[channels == 3 ? k : 0];
    return c;
  }
};

Colour make_colour(ocl::Runtime& rt, int w, int h, std::uint32_t seed) {
  Colour c;
  for (int k = 0; k < 3; ++k) {
    c.host[k] = seed % 2 ? random_texture(w, h, seed + k) : few_levels_image(w, h, seed + k);
    c.device[k] = to_device(rt, c.host[k]);
  }
  return c;
}

TEST(OpenclWeightedMedian, KnownAnswers) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // The tie of tests/cpu: pixel 1 (invalid) sees d = 1 and 2 with equal weights and takes 1; the
  // sub-pixel case: whole disparities 1 4 1 move pixel 1 to 16, the others keep their values.
  struct Case {
    std::vector<std::int16_t> in, out;
  };
  const Case cases[] = {{{16, I, 32}, {16, 16, 32}}, {{20, 56, 23}, {20, 16, 23}}, {{I, I, I}, {I, I, I}}};
  for (const Case& c : cases) {
    Plane<std::int16_t> src(3, 1);
    std::copy(c.in.begin(), c.in.end(), src.row(0));
    Plane<std::uint8_t> gray(3, 1);
    for (int x = 0; x < 3; ++x) gray.at(x, 0) = 100;
    const auto d_gray = to_device(*rt, gray);
    DeviceColour colour;
    colour.channels = 1;
    for (auto& p : colour.plane) p = &d_gray;
    auto d_dst = marked_plane<std::int16_t>(*rt, 3, 1);
    ocl::weighted_median(*rt, to_device(*rt, src), colour, config(1, 1, 10), d_dst);
    EXPECT_EQ(pixels(to_host(*rt, d_dst)), c.out) << "case starting " << c.in[0] << ", " << c.in[1];
    EXPECT_EQ(padding_difference(*rt, d_dst), "");
  }
}

TEST(OpenclWeightedMedian, MatchesCpu) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const std::vector<std::pair<int, int>> sizes = {{1, 1}, {7, 2}, {33, 1}, {97, 5}, {16, 3}, {65, 7}, {41, 23}};
  const std::pair<int, int> ranges[] = {{-160, 640}, {-16 * 1024, -16 * 1000}, {16 * 250, 16 * 300}, {16 * 2000, 16 * 2039}};
  struct ConfigCase {
    int radius, step, sigma;
  };
  const ConfigCase configs[] = {{9, 3, 10}, {1, 1, 10}, {4, 3, 255}, {15, 5, 1}};
  std::uint32_t seed = 500;
  for (auto [w, h] : sizes) {
    for (const MapKind& kind : kMapKinds) {
      for (auto [lo, hi] : ranges) {
        const auto src = random_disparity(w, h, ++seed, lo, hi, kind.invalid, kind.whole);
        const auto d_src = to_device(*rt, src);
        const Colour colour = make_colour(*rt, w, h, ++seed);
        for (const ConfigCase& cc : configs) {
          for (int channels : {1, 3}) {
            Plane<std::int16_t> expected(w, h);
            cpu::weighted_median(src, colour.host_view(channels), config(cc.radius, cc.step, cc.sigma), expected);
            auto d_dst = marked_plane<std::int16_t>(*rt, w, h);
            ocl::weighted_median(*rt, d_src, colour.device_view(channels), config(cc.radius, cc.step, cc.sigma),
                                 d_dst);
            ASSERT_EQ(first_difference(expected, to_host(*rt, d_dst)), "")
                << w << "x" << h << " invalid " << kind.invalid << " range " << lo << ".." << hi << " radius "
                << cc.radius << " step " << cc.step << " sigma " << cc.sigma << " channels " << channels;
            ASSERT_EQ(padding_difference(*rt, d_dst), "") << w << "x" << h;
          }
        }
      }
    }
  }
}

TEST(OpenclWeightedMedian, SplitChannelsMatchesCpu) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 900;
  for (auto [w, h] : awkward_sizes()) {
    for (PixelFormat format : {PixelFormat::Rgb8, PixelFormat::Bgr8}) {
      for (int extra : {0, 13}) {
        const RandomInput input(w, h, format, extra, ++seed);
        DeviceImage image{rt->buffer(input.bytes.size(), CL_MEM_READ_ONLY), w, h,
                          static_cast<std::size_t>(input.view.stride), format};
        rt->queue().enqueueWriteBuffer(image.bytes, CL_TRUE, 0, input.bytes.size(), input.bytes.data());
        std::array<Plane<std::uint8_t>, 3> expected;
        for (auto& p : expected) p.reset(w, h);
        cpu::split_channels(input.view, expected);
        std::array<DevicePlane<std::uint8_t>, 3> planes;
        for (auto& p : planes) p = marked_plane<std::uint8_t>(*rt, w, h);
        ocl::split_channels(*rt, image, planes);
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(first_difference(expected[c], to_host(*rt, planes[c])), "")
              << w << "x" << h << " " << format_name(format) << " channel " << c;
          ASSERT_EQ(padding_difference(*rt, planes[c]), "") << w << "x" << h;
        }
      }
    }
  }
}

}  // namespace
}  // namespace mctstereo::test
