// Band SGM on the opencl backend: the whole frame (left and right maps, the confidence) equals
// the cpu backend bit for bit for the SGM presets and the cases where paths, bands or sizes are
// awkward; frames after the first stay exact; the stage times hold the SGM kernels.
#include <cstdint>
#include <cstring>
#include <ostream>
#include <string>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "opencl_test_util.hpp"
#include "pipeline_cases.hpp"

namespace mctstereo::test {
namespace {

std::string device_of(const detail::opencl::Runtime& rt) { return std::to_string(rt.device().index); }

// opencl equals cpu on `frames` pairs of the case, without and with the right map.
void expect_equal_to_cpu(const PipelineCase& c, const std::string& device, int frames = 1) {
  for (bool right : {false, true}) {
    SCOPED_TRACE(right ? "compute_right" : "left map only");
    MatcherOptions options;
    options.compute_right = right;
    Matcher cpu(c.w, c.h, c.params, Backend::Cpu, options);
    options.device = device;
    Matcher ocl(c.w, c.h, c.params, Backend::OpenCL, options);
    ASSERT_EQ(ocl.backend(), Backend::OpenCL);
    for (int f = 0; f < frames; ++f) {
      SCOPED_TRACE("frame " + std::to_string(f));
      const StereoPair pair = textured_pair(c.w, c.h, c.max_disparity(), 21 + f);
      cpu.compute(pair.left_view(), pair.right_view());
      ocl.compute(pair.left_view(), pair.right_view());
      EXPECT_EQ(describe_difference(pixels(ocl.disparity_q4()), pixels(cpu.disparity_q4()), c.w), "") << "left map";
      if (right)
        EXPECT_EQ(describe_difference(pixels(ocl.right_disparity_q4()), pixels(cpu.right_disparity_q4()), c.w), "")
            << "right map";
      EXPECT_EQ(confidence_difference(ocl, cpu), "") << "confidence";
    }
  }
}

std::vector<PipelineCase> sgm_cases() {
  std::vector<PipelineCase> out;
  for (const char* name : {"balanced", "quality", "sgm-full"}) {
    StereoParams p = preset(name);
    p.num_disparities = 24;
    out.push_back({name, p, 97, 61});
  }
  StereoParams eight = preset("balanced");
  eight.aggregation = Aggregation::Sgm8;
  eight.num_disparities = 20;
  out.push_back({"sgm8_odd_width", eight, 71, 41});
  StereoParams constant = preset("balanced");
  constant.sgm_p2_k = 0;
  constant.num_disparities = 20;
  out.push_back({"constant_p2", constant, 66, 40});
  StereoParams every_level = sgm_every_level();
  every_level.num_disparities = 24;
  out.push_back({"sgm_every_level", every_level, 97, 61});
  StereoParams adaptive = sgm_every_level();
  adaptive.sgm_p2_k = 30;
  adaptive.sgm_p1 = 15;
  adaptive.sgm_p2 = 120;
  adaptive.subpixel = true;
  adaptive.num_disparities = 20;
  out.push_back({"adaptive_p2_subpixel", adaptive, 66, 40});
  StereoParams neg = preset("balanced");
  neg.min_disparity = -7;
  neg.num_disparities = 30;
  out.push_back({"negative_min", neg, 81, 33});
  StereoParams odd = preset("sgm-full");
  odd.num_disparities = 17;
  odd.uniqueness_ratio = 0;
  out.push_back({"odd_73x29_no_uniqueness", odd, 73, 29});
  StereoParams row = preset("balanced");
  row.num_disparities = 12;
  out.push_back({"one_row", row, 64, 1});
  out.push_back({"two_rows", row, 65, 2});
  StereoParams row8 = row;
  row8.aggregation = Aggregation::Sgm8;
  out.push_back({"one_row_sgm8", row8, 33, 1});
  out.push_back({"two_rows_sgm8", row8, 33, 2});
  StereoParams column = row8;
  column.num_disparities = 1;
  out.push_back({"one_column_sgm8", column, 1, 20});
  StereoParams full = preset("sgm-full");
  full.num_disparities = 272;
  out.push_back({"full_range_272", full, 300, 9});
  StereoParams many = preset("balanced");
  many.num_disparities = 264;
  many.min_disparity = -4;
  out.push_back({"band_of_264_disparities", many, 290, 14});
  StereoParams narrow = preset("balanced");
  narrow.sgm_max_band = 5;
  narrow.prior_size = 3;
  narrow.lr_check = false;  // no right map from the sums
  narrow.num_disparities = 24;
  out.push_back({"narrow_band_prior_3_no_lr", narrow, 80, 30});
  StereoParams scaled = preset("balanced");
  scaled.working_scale = 2;
  scaled.pyramid_levels = 2;
  scaled.num_disparities = 32;
  scaled.census_window = 7;
  out.push_back({"working_scale_2_ct7", scaled, 75, 45});
  return out;
}

class OpenclSgmCase : public ::testing::TestWithParam<PipelineCase> {};

TEST_P(OpenclSgmCase, EqualsCpuBitForBit) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  expect_equal_to_cpu(GetParam(), device_of(*rt));
}

INSTANTIATE_TEST_SUITE_P(BandSgm, OpenclSgmCase, ::testing::ValuesIn(sgm_cases()),
                         [](const ::testing::TestParamInfo<PipelineCase>& info) { return info.param.id(); });

// The volume buffers are reused: later frames (other pairs) stay exact.
TEST(OpenclSgm, FramesStayExact) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  StereoParams p = preset("balanced");
  p.num_disparities = 20;
  expect_equal_to_cpu({"frames", p, 60, 36}, device_of(*rt), 3);
}

// Auto on a named device runs SGM there; the SGM kernels' device time is in "match", the
// confidence's in a stage of its own.
TEST(OpenclSgm, AutoRunsOnTheDeviceAndTimesTheStages) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  StereoParams p = preset("balanced");
  p.num_disparities = 16;
  MatcherOptions options;
  options.device = device_of(*rt);
  Matcher m(64, 32, p, Backend::Auto, options);
  EXPECT_EQ(m.backend(), Backend::OpenCL);
  EXPECT_EQ(m.notice(), "");
  EXPECT_EQ(m.confidence().data, nullptr) << "no confidence before the first frame";
  const StereoPair pair = textured_pair(64, 32, 8, 4);
  m.compute(pair.left_view(), pair.right_view());
  std::vector<std::string> labels;
  double match_ms = -1;
  for (const StageTime& t : m.timings()) {
    labels.push_back(t.stage);
    if (t.stage == "match") match_ms = t.ms;
  }
  EXPECT_EQ(labels, (std::vector<std::string>{"upload", "gray", "pyramid", "census", "match", "median", "lr_check",
                                              "speckle", "confidence", "fill", "weighted_median", "upscale",
                                              "output", "download", "frame"}));
  EXPECT_GT(match_ms, 0.0);
  EXPECT_NE(m.confidence().data, nullptr);
}

}  // namespace
}  // namespace mctstereo::test
