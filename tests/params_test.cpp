// Parameters: presets, validation messages that name the parameter and its range.
#include "mctstereo/params.hpp"
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

TEST(Params, EveryPresetIsValidAndDistinct) {
  const auto& names = preset_names();
  ASSERT_EQ(names.size(), 7u);
  for (const auto& n : names) {
    EXPECT_EQ(preset(n).validate(), "") << n;
    EXPECT_FALSE(preset_description(n).empty()) << n;
  }
  EXPECT_EQ(preset("mct-full").census, CensusKind::ModifiedCensus);
  EXPECT_EQ(preset("mct-full").pyramid_levels, 1);
  EXPECT_GT(preset("mr-mct-full").pyramid_levels, 1);
  EXPECT_EQ(preset("mr-mct-5x5").census_window, 5);
  EXPECT_EQ(preset("sgm-full").pyramid_levels, 1);
  EXPECT_EQ(preset("sgm-full").aggregation, Aggregation::Sgm4);
  EXPECT_EQ(preset("balanced").aggregation, Aggregation::Sgm4);
  EXPECT_LT(preset("quality").box_levels, preset("balanced").box_levels);
  EXPECT_GT(preset("quality").sgm_max_band, preset("balanced").sgm_max_band);
  EXPECT_EQ(preset("realtime").aggregation, Aggregation::Box);
}

// Each message names the parameter; the overflow message names the bound and what to change.
TEST(Params, SgmParametersAreChecked) {
  const auto expect_message = [](StereoParams p, const std::string& part) {
    const std::string err = p.validate();
    EXPECT_NE(err.find(part), std::string::npos) << "'" << err << "' lacks '" << part << "'";
  };
  StereoParams p = preset("balanced");
  EXPECT_EQ(p.validate(), "");
  StereoParams q = p;
  q.sgm_p1 = 400;
  q.sgm_p2 = 300;
  expect_message(q, "sgm_p1 = 400 must not exceed sgm_p2 = 300");
  q = p;
  q.sgm_p1 = -1;
  expect_message(q, "sgm_p1 = -1 must be in [0, 16383]");
  q = p;
  q.sgm_p2 = 16384;
  expect_message(q, "sgm_p2 = 16384 must be in [0, 16383]");
  q = p;
  q.sgm_p2_k = 256;
  expect_message(q, "sgm_p2_k = 256 must be in [0, 255]");
  q = p;
  q.sgm_max_band = 0;
  expect_message(q, "sgm_max_band = 0 must be in [1, 255]");
  q = p;
  q.finest_search_radius = 17;
  expect_message(q, "finest_search_radius = 17");
  q = p;
  q.prior_size = 4;
  expect_message(q, "prior_size = 4 must be 3 or 5");
  q = p;
  q.aggregation = Aggregation::Box;
  expect_message(q, "prior_size = 5 needs SGM aggregation");
  q = p;
  q.box_levels = 5;
  expect_message(q, "box_levels = 5 must be in [0, 4]");
  q.box_levels = -1;
  expect_message(q, "box_levels = -1 must be in [0, 4]");
  q = p;
  q.aggregation = Aggregation::Box;
  q.prior_size = 3;
  expect_message(q, "box_levels = 2 needs SGM aggregation");
  // 8 paths x (9 x 9 x 80 + 300) = 54240 fits; 8 x (6480 + 2000) does not.
  q = p;
  q.box_levels = 0;
  q.aggregation = Aggregation::Sgm8;
  q.census_window = 9;
  q.shd_window = 9;
  EXPECT_EQ(q.validate(), "");
  q.sgm_p2 = 2000;
  expect_message(q, "SGM sums could overflow 16 bits: paths (8) x (largest cost 6480");
  expect_message(q, "exceeds 65534");
  // With the finest level matched by box sums, the SGM levels' 3 x 3 costs bound the sums
  // (8 x (720 + 2000)); with one level, that level is SGM's and its 9 x 9 costs count again.
  q.box_levels = 1;
  EXPECT_EQ(q.validate(), "");
  EXPECT_TRUE(q.sgm_at(1) && q.sgm_at(2) && !q.sgm_at(0));
  q.pyramid_levels = 1;
  EXPECT_TRUE(q.sgm_at(0));
  expect_message(q, "SGM sums could overflow 16 bits: paths (8) x (largest cost 6480");
  q.pyramid_levels = 3;
  q.aggregation = Aggregation::Sgm4;  // 4 x 8480 fits
  q.box_levels = 0;
  EXPECT_EQ(q.validate(), "");
}

TEST(Params, WeightedMedianParametersAreChecked) {
  StereoParams p;
  EXPECT_FALSE(p.weighted_median);  // off in the struct defaults
  EXPECT_EQ(p.wm_radius, 9);
  EXPECT_EQ(p.wm_step, 3);
  EXPECT_EQ(p.wm_sigma, 10);
  EXPECT_FALSE(preset("realtime").weighted_median);
  const auto message = [](void (*mutate)(StereoParams&)) {
    StereoParams q;
    q.weighted_median = true;
    mutate(q);
    return q.validate();
  };
  EXPECT_EQ(message([](StereoParams&) {}), "");
  EXPECT_EQ(message([](StereoParams& q) { q.wm_radius = 15, q.wm_step = 15, q.wm_sigma = 255; }), "");
  EXPECT_EQ(message([](StereoParams& q) { q.wm_radius = 1, q.wm_step = 1, q.wm_sigma = 1; }), "");
  EXPECT_EQ(message([](StereoParams& q) { q.wm_radius = 0; }).find("wm_radius = 0 must be in [1, 15]"), 0u);
  EXPECT_NE(message([](StereoParams& q) { q.wm_radius = 16; }).find("wm_radius = 16 must be in [1, 15]"),
            std::string::npos);
  EXPECT_EQ(message([](StereoParams& q) { q.wm_step = 0; }), "wm_step = 0 must be in [1, wm_radius = 9] (pixels)");
  EXPECT_EQ(message([](StereoParams& q) { q.wm_radius = 4, q.wm_step = 5; }),
            "wm_step = 5 must be in [1, wm_radius = 4] (pixels)");
  EXPECT_EQ(message([](StereoParams& q) { q.wm_sigma = 0; }), "wm_sigma = 0 must be in [1, 255] (colour levels)");
  EXPECT_EQ(message([](StereoParams& q) { q.wm_sigma = 256; }), "wm_sigma = 256 must be in [1, 255] (colour levels)");
  // Checked whether or not the stage is on, as every other parameter.
  StereoParams off;
  off.wm_sigma = 0;
  EXPECT_NE(off.validate().find("wm_sigma = 0"), std::string::npos);
}

TEST(Params, UnknownPresetNamesTheKnownOnes) {
  try {
    preset("fastest");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fastest"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("realtime"), std::string::npos);
  }
}

struct BadCase {
  void (*mutate)(StereoParams&);
  const char* must_mention;
};

TEST(Params, ValidateNamesTheParameterAndRange) {
  const BadCase cases[] = {
      {[](StereoParams& p) { p.num_disparities = 0; }, "num_disparities = 0 must be in [1, 2048]"},
      {[](StereoParams& p) { p.num_disparities = -5; }, "num_disparities = -5"},
      {[](StereoParams& p) { p.min_disparity = -2000; }, "min_disparity = -2000 is outside [-1024, 1024]"},
      {[](StereoParams& p) { p.census_window = 4; }, "census_window = 4 must be 3, 5, 7 or 9"},
      {[](StereoParams& p) { p.census_window = 11; }, "census_window = 11"},
      {[](StereoParams& p) { p.shd_window = 2; }, "shd_window = 2 must be 1, 3, 5, 7 or 9"},
      {[](StereoParams& p) { p.coarse_shd_window = 0; }, "coarse_shd_window = 0"},
      {[](StereoParams& p) { p.pyramid_levels = 0; }, "pyramid_levels = 0 must be in [1, 5]"},
      {[](StereoParams& p) { p.search_radius = -1; }, "search_radius = -1"},
      {[](StereoParams& p) { p.median_size = 4; }, "median_size = 4 must be 0 (off), 3 or 5"},
      {[](StereoParams& p) { p.post_median_size = 7; }, "post_median_size = 7"},
      {[](StereoParams& p) { p.lr_threshold = 17; }, "lr_threshold = 17 must be in [0, 16]"},
      {[](StereoParams& p) { p.speckle_size = -1; }, "speckle_size = -1"},
      {[](StereoParams& p) { p.uniqueness_ratio = 101; }, "uniqueness_ratio = 101"},
      {[](StereoParams& p) { p.working_scale = 3; }, "working_scale = 3 must be 1, 2 or 4"},
      {[](StereoParams& p) { p.num_disparities = 2048; p.min_disparity = 10; }, "must be at most 2039"},
      // Found by fuzz/fuzz_params.cpp: the sum overflowed an int (undefined behaviour) before.
      {[](StereoParams& p) { p.num_disparities = 809; p.min_disparity = 2147483559; },
       "min_disparity + num_disparities - 1 = 2147484367 must be at most 2039"},
  };
  for (const BadCase& c : cases) {
    StereoParams p;
    c.mutate(p);
    const std::string err = p.validate();
    EXPECT_NE(err.find(c.must_mention), std::string::npos) << "got: " << err << "\nwanted: " << c.must_mention;
  }
}

TEST(Params, ValidateAgainstTheImage) {
  StereoParams p;
  p.num_disparities = 64;
  EXPECT_EQ(p.validate(64, 10), "");
  EXPECT_NE(p.validate(63, 10).find("wider than the image"), std::string::npos);
  p.min_disparity = 100;
  EXPECT_NE(p.validate(90, 10).find("does not overlap"), std::string::npos);
  EXPECT_NE(p.validate(0, 10).find("at least 1 x 1"), std::string::npos);
  p.min_disparity = -2147483647;  // the largest disparity, computed without overflow
  p.num_disparities = 2048;
  EXPECT_NE(p.validate(90, 10).find("disparity range [-2147483647, -2147481600] does not overlap"), std::string::npos)
      << p.validate(90, 10);
  p.min_disparity = 0;
  p.num_disparities = 0;
  p.census_window = 4;
  const std::string err = p.validate(100, 100);
  EXPECT_NE(err.find("num_disparities"), std::string::npos);
  EXPECT_NE(err.find("census_window"), std::string::npos);  // every problem is reported
}

}  // namespace
}  // namespace mctstereo::test
