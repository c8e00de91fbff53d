// The opencl backend's first stages (to_gray, pyramid_down, census_transform) equal the reference
// bit for bit at awkward sizes, for every pixel format and census variant, and write only the pixels
// of the caller's planes (row padding and slack keep what they held).
#include <vector>

#include "opencl/stages.hpp"
#include "opencl_test_util.hpp"
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::CensusCodes;
using detail::CensusConfig;
using detail::opencl::DeviceCodes;
using detail::opencl::DeviceImage;
using detail::opencl::DevicePlane;
using detail::opencl::Runtime;

// Census code planes as the pipeline driver allocates them: codes.plane[k] for the words the
// window needs, marked; the others left empty.
DeviceCodes marked_codes(Runtime& rt, int w, int h, int window) {
  DeviceCodes codes;
  codes.words = detail::census_words(window);
  for (int k = 0; k < codes.words; ++k) codes.plane[k] = marked_plane<std::uint32_t>(rt, w, h);
  return codes;
}

// ---------------------------------------------------------------------------------------------
// to_gray

// RandomInput's bytes uploaded as the caller's bytes: the device buffer ends right after the last
// pixel.
struct DeviceInput {
  RandomInput host;
  DeviceImage device;
  DeviceInput(Runtime& rt, int w, int h, PixelFormat format, int extra, std::uint32_t seed)
      : host(w, h, format, extra, seed) {
    device.bytes = rt.buffer(host.bytes.size(), CL_MEM_READ_ONLY);
    rt.queue().enqueueWriteBuffer(device.bytes, CL_TRUE, 0, host.bytes.size(), host.bytes.data());
    device.width = w;
    device.height = h;
    device.stride = static_cast<std::size_t>(host.view.stride);
    device.format = format;
  }
};

TEST(OpenclGray, EqualsReferenceForEveryFormatSizeAndStride) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 1;
  for (auto [w, h] : awkward_sizes()) {
    for (PixelFormat format : {PixelFormat::Gray8, PixelFormat::Rgb8, PixelFormat::Bgr8}) {
      for (int extra : {0, 13}) {
        const DeviceInput input(*rt, w, h, format, extra, seed++);
        Plane<std::uint8_t> expected(w, h);
        detail::reference::to_gray(input.host.view, expected);
        DevicePlane<std::uint8_t> luma = marked_plane<std::uint8_t>(*rt, w, h);
        detail::opencl::to_gray(*rt, input.device, luma);
        const std::string what = std::to_string(w) + "x" + std::to_string(h) + " " + format_name(format) +
                                 " stride +" + std::to_string(extra);
        EXPECT_EQ(first_difference(to_host(*rt, luma), expected), "") << what;
        EXPECT_EQ(padding_difference(*rt, luma), "") << what;
      }
    }
  }
}

TEST(OpenclGray, KnownLumaValues) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // 40 pixels: two whole 16-pixel chunks and a tail of 8.
  const auto [rgb, want] = known_luma_row();
  DeviceImage image{rt->buffer(rgb.size()), 40, 1, rgb.size(), PixelFormat::Rgb8};
  rt->queue().enqueueWriteBuffer(image.bytes, CL_TRUE, 0, rgb.size(), rgb.data());
  DevicePlane<std::uint8_t> luma = marked_plane<std::uint8_t>(*rt, 40, 1);
  detail::opencl::to_gray(*rt, image, luma);
  const Plane<std::uint8_t> out = to_host(*rt, luma);
  for (int x = 0; x < 40; ++x) ASSERT_EQ(out.at(x, 0), want[x]) << "x = " << x;
}

// ---------------------------------------------------------------------------------------------
// pyramid_down

TEST(OpenclPyramid, EqualsReferenceOnOddAndEvenSizes) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 100;
  for (auto [w, h] : pyramid_sizes()) {
    const Plane<std::uint8_t> src = random_image(w, h, seed++);
    Plane<std::uint8_t> expected((w + 1) / 2, (h + 1) / 2);
    detail::reference::pyramid_down(src, expected);
    const DevicePlane<std::uint8_t> src_device = to_device(*rt, src);
    DevicePlane<std::uint8_t> dst = marked_plane<std::uint8_t>(*rt, (w + 1) / 2, (h + 1) / 2);
    detail::opencl::pyramid_down(*rt, src_device, dst);
    EXPECT_EQ(first_difference(to_host(*rt, dst), expected), "") << w << "x" << h;
    EXPECT_EQ(padding_difference(*rt, dst), "") << w << "x" << h;
  }
}

TEST(OpenclPyramid, ImpulseGivesTheBinomialWeights) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // The impulse at (50, 4) lies in the whole-vector part of the row (output columns 16..31).
  Plane<std::uint8_t> src(99, 9);
  src.at(50, 4) = 255;
  DevicePlane<std::uint8_t> dst = marked_plane<std::uint8_t>(*rt, 50, 5);
  detail::opencl::pyramid_down(*rt, to_device(*rt, src), dst);
  const Plane<std::uint8_t> out = to_host(*rt, dst);
  EXPECT_EQ(out.at(25, 2), (36 * 255 + 128) >> 8);
  EXPECT_EQ(out.at(24, 2), (6 * 255 + 128) >> 8);
  EXPECT_EQ(out.at(26, 1), (1 * 255 + 128) >> 8);
  EXPECT_EQ(out.at(23, 2), 0);
}

TEST(OpenclPyramid, WrongDestinationSizeIsAnError) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const DevicePlane<std::uint8_t> src = marked_plane<std::uint8_t>(*rt, 31, 7);
  DevicePlane<std::uint8_t> dst = marked_plane<std::uint8_t>(*rt, 15, 4);  // 16 x 4 expected
  EXPECT_THROW(detail::opencl::pyramid_down(*rt, src, dst), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// census_transform

// First difference between the device codes and the reference's, or empty when equal; also checks
// that no code plane's padding was written.
std::string code_difference(Runtime& rt, const DeviceCodes& got, const CensusCodes& expected) {
  for (int k = 0; k < expected.words; ++k) {
    const std::string diff = first_difference(to_host(rt, got.plane[k]), expected.plane[k]);
    if (!diff.empty()) return "word " + std::to_string(k) + " " + diff;
    const std::string padding = padding_difference(rt, got.plane[k]);
    if (!padding.empty()) return "word " + std::to_string(k) + " " + padding;
  }
  return {};
}

std::string device_vs_reference(Runtime& rt, const Plane<std::uint8_t>& image, const CensusConfig& config) {
  const int w = image.width(), h = image.height();
  CensusCodes expected = code_planes(w, h, config.window);
  detail::reference::census_transform(image, config, expected);
  DeviceCodes got = marked_codes(rt, w, h, config.window);
  detail::opencl::census_transform(rt, to_device(rt, image), config, got);
  return code_difference(rt, got, expected);
}

class OpenclCensus : public ::testing::TestWithParam<CensusConfig> {};

TEST_P(OpenclCensus, EqualsReferenceOnNoiseAtAwkwardSizes) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 7;
  for (auto [w, h] : awkward_sizes())
    EXPECT_EQ(device_vs_reference(*rt, random_image(w, h, seed++), GetParam()), "") << w << "x" << h;
}

TEST_P(OpenclCensus, EqualsReferenceWithTiesAndNarrowImages) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 70;
  // Widths around 16 + 2 r, where work-items change between whole vectors and clamped pixels.
  for (auto [w, h] : {std::pair{97, 13}, std::pair{64, 5}, std::pair{5, 6}, std::pair{18, 3}, std::pair{20, 3},
                      std::pair{22, 3}, std::pair{24, 3}, std::pair{41, 2}})
    EXPECT_EQ(device_vs_reference(*rt, few_levels_image(w, h, seed++), GetParam()), "") << w << "x" << h;
}

INSTANTIATE_TEST_SUITE_P(OpenclCensusVariants, OpenclCensus, ::testing::ValuesIn(all_census_configs()),
                         [](const ::testing::TestParamInfo<CensusConfig>& info) {
                           return census_config_name(info.param);
                         });

// The census string of pixel (cx, 2) as '0'/'1' characters, first neighbour first.
std::string centre_string(Runtime& rt, const Plane<std::uint8_t>& image, int cx, const CensusConfig& config) {
  DeviceCodes codes = marked_codes(rt, image.width(), image.height(), config.window);
  detail::opencl::census_transform(rt, to_device(rt, image), config, codes);
  const int bits = config.window * config.window - 1;
  std::string s;
  for (int k = 0; k < codes.words; ++k) {
    const int in_word = k == codes.words - 1 ? bits - 32 * k : 32;
    const std::uint32_t word = to_host(rt, codes.plane[k]).at(cx, 2);
    for (int b = in_word - 1; b >= 0; --b) s += ((word >> b) & 1u) ? '1' : '0';
  }
  return s;
}

TEST(OpenclCensusKnownAnswer, ThesisExample) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // DESIGN.md section 2: the 5x5 window of the thesis, alone (every pixel clamped) and in the
  // middle of a wider image (pixel 100 coded by a whole-vector work-item).
  constexpr std::uint8_t kWindow[5][5] = {{41, 154, 115, 211, 27}, {203, 67, 21, 137, 246}, {79, 167, 58, 255, 1},
                                          {135, 176, 233, 20, 198}, {42, 191, 39, 113, 209}};
  for (int left : {0, 98}) {
    Plane<std::uint8_t> image(left == 0 ? 5 : 200, 5);
    for (int y = 0; y < 5; ++y)
      for (int x = 0; x < 5; ++x) image.at(left + x, y) = kWindow[y][x];
    const int cx = left + 2;
    EXPECT_EQ(centre_string(*rt, image, cx, {CensusKind::Census, 5, MeanKernel::Box}), "100010010000010001010100");
    EXPECT_EQ(centre_string(*rt, image, cx, {CensusKind::Census, 3, MeanKernel::Box}), "01000001");
    EXPECT_EQ(centre_string(*rt, image, cx, {CensusKind::ModifiedCensus, 5, MeanKernel::Box}),
              "101010110010010001010110");
    EXPECT_EQ(centre_string(*rt, image, cx, {CensusKind::ModifiedCensus, 3, MeanKernel::Gaussian}), "11000001");
  }
}

TEST(OpenclCensusPlanes, WritesTheCallersPlanesAndChecksThem) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const Plane<std::uint8_t> image = random_texture(37, 6, 3);
  const DevicePlane<std::uint8_t> device_image = to_device(*rt, image);
  const CensusConfig config{CensusKind::ModifiedCensus, 7, MeanKernel::Gaussian};
  DeviceCodes codes = marked_codes(*rt, 37, 6, 7);
  ASSERT_EQ(codes.words, 2);
  const cl_mem plane0 = codes.plane[0].buffer(), plane1 = codes.plane[1].buffer();
  detail::opencl::census_transform(*rt, device_image, config, codes);
  // The same buffers, now holding the codes; the third plane, which 48 bits do not need, stays empty.
  EXPECT_EQ(codes.plane[0].buffer(), plane0);
  EXPECT_EQ(codes.plane[1].buffer(), plane1);
  EXPECT_EQ(codes.plane[2].buffer(), nullptr);
  CensusCodes expected;
  expected.words = 2;
  for (int k = 0; k < 2; ++k) expected.plane[k].reset(37, 6);
  detail::reference::census_transform(image, config, expected);
  EXPECT_EQ(code_difference(*rt, codes, expected), "");

  // Planes that do not fit the window or the image are the caller's error, reported before any work.
  DeviceCodes one_word = marked_codes(*rt, 37, 6, 5);
  EXPECT_THROW(detail::opencl::census_transform(*rt, device_image, config, one_word), std::invalid_argument);
  DeviceCodes smaller = marked_codes(*rt, 36, 6, 7);
  EXPECT_THROW(detail::opencl::census_transform(*rt, device_image, config, smaller), std::invalid_argument);
  DeviceCodes window4 = marked_codes(*rt, 37, 6, 5);
  EXPECT_THROW(detail::opencl::census_transform(*rt, device_image, {CensusKind::Census, 4, MeanKernel::Box}, window4),
               std::invalid_argument);
}

}  // namespace
}  // namespace mctstereo::test
