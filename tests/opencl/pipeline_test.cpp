// The whole pipeline on the opencl backend: equal to the cpu backend bit for bit (left and right
// maps) for every preset and the awkward cases, colour input with padded rows, several frames and
// matchers on one device; the float map, the stage times, device choice and Backend::Auto.
#include <cmath>
#include <cstdint>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "opencl_test_util.hpp"
#include "frame_reference.hpp"
#include "pipeline_cases.hpp"

namespace mctstereo::test {
namespace {

// The device the tests run on, as MatcherOptions::device names it.
std::string device_of(const detail::opencl::Runtime& rt) { return std::to_string(rt.device().index); }

struct Maps {
  std::vector<std::int16_t> left, right;
};

Maps run(const ImageView& left, const ImageView& right, const StereoParams& params, Backend backend,
         const std::string& device, bool compute_right) {
  MatcherOptions options;
  options.compute_right = compute_right;
  options.device = device;
  Matcher m(left.width, left.height, params, backend, options);
  EXPECT_EQ(m.backend(), backend);
  m.compute(left, right);
  return {pixels(m.disparity_q4()), compute_right ? pixels(m.right_disparity_q4()) : std::vector<std::int16_t>{}};
}

// opencl equals cpu on the pair: the left map alone (the right view's refinement stops at the LR
// check) and both maps with compute_right.
void expect_equal_to_cpu(const StereoPair& pair, const StereoParams& params, const std::string& device) {
  const int w = pair.left.width();
  for (bool right : {false, true}) {
    const Maps cpu = run(pair.left_view(), pair.right_view(), params, Backend::Cpu, "", right);
    const Maps ocl = run(pair.left_view(), pair.right_view(), params, Backend::OpenCL, device, right);
    EXPECT_EQ(describe_difference(ocl.left, cpu.left, w), "") << "left map, compute_right " << right;
    if (right) EXPECT_EQ(describe_difference(ocl.right, cpu.right, w), "") << "right map";
  }
}

class OpenclPipelineCase : public ::testing::TestWithParam<PipelineCase> {};

TEST_P(OpenclPipelineCase, EqualsCpuBitForBit) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const PipelineCase& c = GetParam();
  expect_equal_to_cpu(textured_pair(c.w, c.h, c.max_disparity(), 11), c.params, device_of(*rt));
}

// One test each: a case builds its own kernels (on PoCL, a fraction of a second per program).
INSTANTIATE_TEST_SUITE_P(PresetsAndAwkwardCases, OpenclPipelineCase, ::testing::ValuesIn(pipeline_cases()),
                         [](const ::testing::TestParamInfo<PipelineCase>& info) { return info.param.id(); });

// The temporal prior on the device, for every pipeline case (temporal radius 0, so that realtime's
// finer levels take it too): frames whose left view stays while the disparities change (the prior
// is taken, and wrong), then a cut; both maps equal to the cpu backend's frame after frame (cpu
// equals the reference: tests/temporal_test.cpp), and after reset_temporal() the frame is matched
// alone.
TEST(OpenclPipeline, TemporalPriorEqualsCpuFrameAfterFrame) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  for (PipelineCase c : pipeline_cases()) {
    SCOPED_TRACE(c.name);
    c.params.temporal = true;
    c.params.temporal_radius = 0;
    const int d = c.max_disparity();
    const StereoPair frames[] = {textured_pair(c.w, c.h, d, 11), textured_pair(c.w, c.h, d, 11),
                                 textured_pair(c.w, c.h, std::max(d - 3, 0), 11), textured_pair(c.w, c.h, d, 12)};
    MatcherOptions options;
    options.compute_right = true;
    Matcher cpu(c.w, c.h, c.params, Backend::Cpu, options);
    options.device = device_of(*rt);
    Matcher ocl(c.w, c.h, c.params, Backend::OpenCL, options);
    ASSERT_EQ(ocl.backend(), Backend::OpenCL);
    const auto expect_same_maps = [&](const std::string& what) {
      EXPECT_EQ(describe_difference(pixels(ocl.disparity_q4()), pixels(cpu.disparity_q4()), c.w), "") << what;
      EXPECT_EQ(describe_difference(pixels(ocl.right_disparity_q4()), pixels(cpu.right_disparity_q4()), c.w), "")
          << what << ", right map";
    };
    for (std::size_t f = 0; f < std::size(frames); ++f) {
      cpu.compute(frames[f].left_view(), frames[f].right_view());
      ocl.compute(frames[f].left_view(), frames[f].right_view());
      EXPECT_EQ(ocl.used_temporal_prior(), f > 0) << "frame " << f;
      expect_same_maps("frame " + std::to_string(f));
    }
    cpu.reset_temporal();
    ocl.reset_temporal();
    cpu.compute(frames[1].left_view(), frames[1].right_view());
    ocl.compute(frames[1].left_view(), frames[1].right_view());
    EXPECT_FALSE(ocl.used_temporal_prior());
    expect_same_maps("after reset_temporal()");
  }
}

// Every preset against the recipe of the whole frame written apart from the drivers
// (frame_reference.hpp), on colour input whose channels differ, with the right map and the
// confidence: a bug in the OpenCL pipeline's own recipe shows even where cpu would share it.
TEST(OpenclPipeline, EveryPresetEqualsTheRecipeOnColourInput) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const ColourPair pair(89, 41, 12, 43, PixelFormat::Bgr8, 5);
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    p.num_disparities = 20;
    MatcherOptions options;
    options.compute_right = true;
    options.compute_confidence = true;
    const FrameResult expected = reference_frame(pair.left.view, pair.luma.right_view(), p, options);
    options.device = device_of(*rt);
    Matcher m(89, 41, p, Backend::OpenCL, options);
    m.compute(pair.left.view, pair.luma.right_view());
    EXPECT_EQ(difference_from_recipe(m, expected, options), "") << name;
  }
}

// Box aggregation with compute_confidence: the map and the confidence equal the cpu backend's,
// at an odd size, with and without the right map.
TEST(OpenclPipeline, BoxConfidenceEqualsCpu) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const StereoPair pair = textured_pair(93, 37, 10, 5);
  for (const char* name : {"realtime", "mr-mct-5x5"}) {
    StereoParams p = preset(name);
    p.num_disparities = 20;
    for (bool right : {false, true}) {
      SCOPED_TRACE(std::string(name) + (right ? ", compute_right" : ""));
      MatcherOptions options;
      options.compute_confidence = true;
      options.compute_right = right;
      Matcher cpu(93, 37, p, Backend::Cpu, options);
      options.device = device_of(*rt);
      Matcher ocl(93, 37, p, Backend::OpenCL, options);
      cpu.compute(pair.left_view(), pair.right_view());
      ocl.compute(pair.left_view(), pair.right_view());
      EXPECT_EQ(describe_difference(pixels(ocl.disparity_q4()), pixels(cpu.disparity_q4()), 93), "");
      EXPECT_EQ(confidence_difference(ocl, cpu), "");
    }
  }
}

// Colour views whose channels differ (so the conversion weights matter), in rows longer than the
// pixels, as RGB on the left and BGR on the right.
TEST(OpenclPipeline, ColourInputWithPaddedRowsEqualsCpu) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 71, h = 35, stride = 3 * w + 7;
  const StereoPair pair = textured_pair(w, h, 12, 5);
  const Plane<std::uint8_t> tint = random_texture(w, h, 6);
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(stride) * h, 0xee), bgr(rgb.size(), 0xee);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::uint8_t* l = &rgb[static_cast<std::size_t>(y) * stride + 3 * x];
      std::uint8_t* r = &bgr[static_cast<std::size_t>(y) * stride + 3 * x];
      l[0] = pair.left.at(x, y), l[1] = tint.at(x, y), l[2] = static_cast<std::uint8_t>(255 - pair.left.at(x, y));
      r[2] = pair.right.at(x, y), r[1] = tint.at(x, y), r[0] = static_cast<std::uint8_t>(255 - pair.right.at(x, y));
    }
  const ImageView left{rgb.data(), w, h, stride, PixelFormat::Rgb8};
  const ImageView right{bgr.data(), w, h, stride, PixelFormat::Bgr8};
  StereoParams p = preset("balanced");
  p.num_disparities = 16;
  const Maps cpu = run(left, right, p, Backend::Cpu, "", true);
  const Maps ocl = run(left, right, p, Backend::OpenCL, device_of(*rt), true);
  EXPECT_EQ(describe_difference(ocl.left, cpu.left, w), "");
  EXPECT_EQ(describe_difference(ocl.right, cpu.right, w), "");
  // Gray rows with padding go straight to the device: the same map as a packed copy would give.
  const ImageView left_gray = pair.left_view();
  ASSERT_GT(left_gray.stride, w);
  const Maps gray_cpu = run(left_gray, pair.right_view(), p, Backend::Cpu, "", false);
  const Maps gray_ocl = run(left_gray, pair.right_view(), p, Backend::OpenCL, device_of(*rt), false);
  EXPECT_EQ(describe_difference(gray_ocl.left, gray_cpu.left, w), "");
}

// The colour-weighted median on colour input (RGB with padded rows, BGR packed; working scales
// 1 and 2), and on gray input: opencl == cpu.
TEST(OpenclPipeline, WeightedMedianOnColourInputEqualsCpu) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 89, h = 41;
  const ColourPair rgb(w, h, 14, 31, PixelFormat::Rgb8, 5), bgr(w, h, 14, 31, PixelFormat::Bgr8, 0);
  const StereoPair& pair = rgb.luma;
  for (int scale : {1, 2}) {
    StereoParams p = preset("balanced");
    p.weighted_median = true;
    p.num_disparities = 24;
    p.working_scale = scale;
    for (const ImageView& left : {rgb.left.view, bgr.left.view, pair.left_view()}) {
      for (bool right : {false, true}) {
        const Maps cpu = run(left, pair.right_view(), p, Backend::Cpu, "", right);
        const Maps ocl = run(left, pair.right_view(), p, Backend::OpenCL, device_of(*rt), right);
        EXPECT_EQ(describe_difference(ocl.left, cpu.left, w), "")
            << "scale " << scale << " format " << format_name(left.format) << " right " << right;
        if (right) EXPECT_EQ(describe_difference(ocl.right, cpu.right, w), "") << "right map";
      }
    }
  }
}

// Buffers are reused frame after frame, and matchers of other sizes and parameters share the
// device (and its programs) between them.
TEST(OpenclPipeline, FramesAndMatchersOnOneDeviceStayExact) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  MatcherOptions options;
  options.device = device_of(*rt);
  StereoParams pa = preset("balanced"), pb = preset("mr-mct-5x5");
  pa.num_disparities = 20;
  pb.num_disparities = 28;
  Matcher a(80, 48, pa, Backend::OpenCL, options), b(66, 40, pb, Backend::OpenCL, options);
  Matcher a_cpu(80, 48, pa, Backend::Cpu), b_cpu(66, 40, pb, Backend::Cpu);
  for (std::uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    const StereoPair pair_a = textured_pair(80, 48, 15, seed), pair_b = textured_pair(66, 40, 20, seed + 10);
    a.compute(pair_a.left_view(), pair_a.right_view());
    b.compute(pair_b.left_view(), pair_b.right_view());
    a_cpu.compute(pair_a.left_view(), pair_a.right_view());
    b_cpu.compute(pair_b.left_view(), pair_b.right_view());
    EXPECT_EQ(describe_difference(pixels(a.disparity_q4()), pixels(a_cpu.disparity_q4()), 80), "");
    EXPECT_EQ(describe_difference(pixels(b.disparity_q4()), pixels(b_cpu.disparity_q4()), 66), "");
  }
}

TEST(OpenclPipeline, FloatMapAndInvalidValueAsCpu) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  StereoParams p = preset("balanced");
  p.min_disparity = -3;
  p.num_disparities = 20;
  p.fill = FillMode::None;
  p.uniqueness_ratio = 30;  // leaves invalid pixels
  p.weighted_median = false;  // which would give them the value of their neighbours
  const StereoPair pair = textured_pair(120, 40, 10, 9);
  MatcherOptions options;
  options.device = device_of(*rt);
  Matcher ocl(120, 40, p, Backend::OpenCL, options), cpu(120, 40, p, Backend::Cpu);
  ocl.compute(pair.left_view(), pair.right_view());
  cpu.compute(pair.left_view(), pair.right_view());
  EXPECT_EQ(ocl.invalid_q4(), -4 * 16);
  int invalid = 0;
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 120; ++x) {
      const float f = ocl.disparity().at(x, y), g = cpu.disparity().at(x, y);
      ASSERT_EQ(std::isnan(f), std::isnan(g)) << x << ", " << y;
      if (std::isnan(f)) {
        ++invalid;
        EXPECT_EQ(ocl.disparity_q4().at(x, y), ocl.invalid_q4());
      } else {
        ASSERT_EQ(f, g) << x << ", " << y;
        EXPECT_EQ(f, ocl.disparity_q4().at(x, y) / 16.0f);
      }
    }
  EXPECT_GT(invalid, 0);
  // The float map follows the next frame too.
  const StereoPair other = textured_pair(120, 40, 10, 10);
  ocl.compute(other.left_view(), other.right_view());
  cpu.compute(other.left_view(), other.right_view());
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 120; ++x) {
      const float f = ocl.disparity().at(x, y), g = cpu.disparity().at(x, y);
      ASSERT_TRUE(f == g || (std::isnan(f) && std::isnan(g))) << x << ", " << y;
    }
}

TEST(OpenclPipeline, TimingsNameTheKernelsAndTheHostSteps) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  StereoParams p = preset("realtime");  // no speckle removal, working scale 1
  p.num_disparities = 16;
  MatcherOptions options;
  options.device = device_of(*rt);
  Matcher m(64, 32, p, Backend::OpenCL, options);
  EXPECT_NE(m.device_name().find(rt->device().name), std::string::npos) << m.device_name();
  EXPECT_TRUE(m.notice().empty());
  const StereoPair pair = textured_pair(64, 32, 8, 4);
  m.compute(pair.left_view(), pair.right_view());
  std::vector<std::string> labels;
  for (const StageTime& t : m.timings()) labels.push_back(t.stage);
  EXPECT_EQ(labels, (std::vector<std::string>{"upload", "gray", "pyramid", "census", "match", "median", "lr_check",
                                              "speckle", "fill", "upscale", "output", "download", "frame"}));
  const auto ms = [&](const std::string& stage) {
    for (const StageTime& t : m.timings())
      if (t.stage == stage) return t.ms;
    return -1.0;
  };
  // Gray input needs no conversion kernel, speckle removal is off and the scale is 1.
  EXPECT_EQ(ms("gray"), 0.0);
  EXPECT_EQ(ms("speckle"), 0.0);
  EXPECT_EQ(ms("upscale"), 0.0);
  EXPECT_GT(ms("frame"), 0.0);
  for (const StageTime& t : m.timings()) EXPECT_GE(t.ms, 0.0) << t.stage;
}

TEST(OpenclPipeline, DeviceChoiceAndAuto) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  StereoParams p = preset("realtime");
  p.num_disparities = 8;
  MatcherOptions options;
  options.device = "999";
  try {
    Matcher(32, 16, p, Backend::OpenCL, options);
    FAIL() << "device 999 should not exist";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("999 does not exist"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(rt->device().name), std::string::npos) << "lists the devices: " << e.what();
  }

  // Auto takes the device a selector names, and falls back with a notice when it names none.
  options.device = device_of(*rt);
  const Matcher named(32, 16, p, Backend::Auto, options);
  EXPECT_EQ(named.backend(), Backend::OpenCL);
  EXPECT_EQ(named.notice(), "");
  options.device = "no-such-opencl-device";
  const Matcher fallback(32, 16, p, Backend::Auto, options);
  EXPECT_EQ(fallback.backend(), Backend::Cpu);
  EXPECT_EQ(fallback.notice(), "no OpenCL device matches 'no-such-opencl-device': running on the cpu backend");
  EXPECT_EQ(fallback.device_name(), "");

  // Without a selector, Auto wants a GPU.
  bool gpu = false;
  for (const OpenclDevice& d : opencl_devices()) gpu = gpu || d.type == "GPU";
  const Matcher automatic(32, 16, p, Backend::Auto);
  EXPECT_EQ(automatic.backend(), gpu ? Backend::OpenCL : Backend::Cpu);
  EXPECT_EQ(automatic.notice(), gpu ? "" : "no OpenCL GPU found: running on the cpu backend");
}

TEST(OpenclPipeline, DevicesAndBackendNames) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  EXPECT_TRUE(have_opencl());
  const auto devices = opencl_devices();
  const auto internal = detail::opencl::list_devices();
  ASSERT_EQ(devices.size(), internal.size());
  for (std::size_t i = 0; i < devices.size(); ++i) {
    EXPECT_EQ(devices[i].index, static_cast<int>(i));
    EXPECT_EQ(devices[i].name, internal[i].name);
    EXPECT_EQ(devices[i].type == "GPU", internal[i].gpu);
    EXPECT_GT(devices[i].compute_units, 0);
    EXPECT_GT(devices[i].global_memory, 0u);
  }
  EXPECT_EQ(parse_backend("opencl"), Backend::OpenCL);
  EXPECT_EQ(parse_backend("auto"), Backend::Auto);
  EXPECT_EQ(to_string(Backend::OpenCL), "opencl");
  EXPECT_EQ(to_string(Backend::Auto), "auto");
  try {
    parse_backend("gpu");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("reference, cpu, opencl, auto"), std::string::npos) << e.what();
  }
}

// The largest image the parameters allow needs an input buffer of 3 x 32768 x 32768 bytes: more
// than most devices can hold in one buffer. The matcher says so before anything else is allocated.
TEST(OpenclPipeline, ImageTooLargeForTheDeviceIsAClearError) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const std::uint64_t input_bytes = std::uint64_t{3} * 32768 * 32768;
  if (rt->device().max_allocation == 0 || rt->device().max_allocation >= input_bytes)
    GTEST_SKIP() << "the device holds a buffer of " << input_bytes << " bytes";
  StereoParams p = preset("realtime");
  p.num_disparities = 64;
  MatcherOptions options;
  options.device = device_of(*rt);
  try {
    Matcher(32768, 32768, p, Backend::OpenCL, options);
    FAIL() << "the matcher should not fit";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(rt->device().name), std::string::npos) << what;
    EXPECT_NE(what.find("cannot hold a buffer of " + std::to_string(input_bytes) + " bytes"), std::string::npos)
        << what;
  }
}

TEST(OpenclPipeline, RejectsWrongInputAsCpu) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  MatcherOptions options;
  options.device = device_of(*rt);
  expect_rejects_wrong_input(Backend::OpenCL, options);
}

}  // namespace
}  // namespace mctstereo::test
