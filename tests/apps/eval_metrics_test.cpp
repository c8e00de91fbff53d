// The Middlebury v2 metrics of `mctstereo eval` on small maps whose scores are counted by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "eval_metrics.hpp"

namespace mctstereo::app {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// A row-major map that owns its values, with a view for the metrics.
template <typename T>
struct Map {
  int width, height;
  std::vector<T> values;
  MapView<const T> view() const { return {values.data(), width, height, width}; }
};

// 4 x 3 maps. Ground truth: one unknown pixel (NaN) at (3, 0).
const Map<float> kGroundTruth{4, 3, {1, 2, 3, kNaN,  //
                                     1, 2, 3, 4,     //
                                     1, 2, 3, 4}};
// Estimate errors: (1,0) off by exactly 1 (good: the test is > 1), (2,0) off by 1.5 (bad), (3,0)
// wrong but its ground truth is unknown, (0,1) invalid (NaN), (3,1) invalid (+INF), (1,2) off by
// 3 (bad), (2,2) off by 0.25 (good).
const Map<float> kEstimate{4, 3, {1, 3, 4.5f, 9,     //
                                  kNaN, 2, 3, kInf,  //
                                  1, 5, 3.25f, 4}};

TEST(EvalMetrics, BadPixelsOverTheWholeMaskCountInvalidAsBadAndSkipUnknownTruth) {
  const Map<std::uint8_t> all{4, 3, std::vector<std::uint8_t>(12, 255)};
  const RegionScore s = bad_pixels(kEstimate.view(), kGroundTruth.view(), all.view());
  EXPECT_EQ(s.pixels, 11);  // 12 minus the unknown ground truth
  EXPECT_EQ(s.bad, 4);      // (2,0), (0,1) NaN, (3,1) INF, (1,2)
  EXPECT_DOUBLE_EQ(s.percent(), 100.0 * 4 / 11);
}

TEST(EvalMetrics, BadPixelsOnlyCountTheMaskValue) {
  // disc.png style: 255 = in the region, 128 = other non-occluded pixel, 0 = excluded.
  const Map<std::uint8_t> disc{4, 3, {255, 128, 255, 255,  //
                                      255, 0, 128, 128,    //
                                      0, 255, 255, 0}};
  const RegionScore s = bad_pixels(kEstimate.view(), kGroundTruth.view(), disc.view());
  // In the region: (0,0) good, (2,0) bad, (3,0) unknown truth, (0,1) invalid, (1,2) bad, (2,2) good.
  EXPECT_EQ(s.pixels, 5);
  EXPECT_EQ(s.bad, 3);
  const RegionScore other = bad_pixels(kEstimate.view(), kGroundTruth.view(), disc.view(), 128);
  EXPECT_EQ(other.pixels, 3);  // (1,0) good, (2,1) good, (3,1) invalid
  EXPECT_EQ(other.bad, 1);
}

TEST(EvalMetrics, ThresholdIsStrict) {
  const Map<std::uint8_t> all{4, 3, std::vector<std::uint8_t>(12, 255)};
  // At 0.5 px the 1-px error of (1,0) and 0.25-px error of (2,2): only the first turns bad.
  EXPECT_EQ(bad_pixels(kEstimate.view(), kGroundTruth.view(), all.view(), 255, 0.5f).bad, 5);
  // At 3 px only the invalid pixels stay bad: an error of exactly 3 is not above the threshold.
  EXPECT_EQ(bad_pixels(kEstimate.view(), kGroundTruth.view(), all.view(), 255, 3.0f).bad, 2);
}

TEST(EvalMetrics, EmptyRegionScoresZero) {
  const Map<std::uint8_t> none{4, 3, std::vector<std::uint8_t>(12, 0)};
  const RegionScore s = bad_pixels(kEstimate.view(), kGroundTruth.view(), none.view());
  EXPECT_EQ(s.pixels, 0);
  EXPECT_EQ(s.percent(), 0.0);
}

TEST(EvalMetrics, DensityIsThePercentOfFiniteEstimates) {
  EXPECT_DOUBLE_EQ(density_percent(kEstimate.view()), 100.0 * 10 / 12);
  const Map<float> all_invalid{2, 2, {kNaN, kInf, -kInf, kNaN}};
  EXPECT_EQ(density_percent(all_invalid.view()), 0.0);
}

TEST(EvalMetrics, MiddleburyV2ScoresEachMask) {
  const Map<std::uint8_t> nonocc{4, 3, {255, 255, 255, 0,  //
                                        255, 255, 255, 0,  //
                                        255, 255, 255, 0}};
  const Map<std::uint8_t> all{4, 3, std::vector<std::uint8_t>(12, 255)};
  const Map<std::uint8_t> disc{4, 3, {128, 128, 255, 0,  //
                                      255, 128, 128, 0,  //
                                      128, 255, 128, 0}};
  const MiddleburyV2Score s =
      score_middlebury_v2(kEstimate.view(), kGroundTruth.view(), nonocc.view(), all.view(), disc.view());
  EXPECT_EQ(s.nonocc.pixels, 9);
  EXPECT_EQ(s.nonocc.bad, 3);  // (2,0), (0,1), (1,2)
  EXPECT_EQ(s.all.pixels, 11);
  EXPECT_EQ(s.all.bad, 4);
  EXPECT_EQ(s.disc.pixels, 3);  // (2,0), (0,1), (1,2): all bad
  EXPECT_EQ(s.disc.bad, 3);
  EXPECT_DOUBLE_EQ(s.disc.percent(), 100.0);
  EXPECT_DOUBLE_EQ(s.density_percent, 100.0 * 10 / 12);
}

TEST(EvalMetrics, MapsOfDifferentSizesAreRejected) {
  const Map<float> small{2, 2, {1, 1, 1, 1}};
  const Map<std::uint8_t> mask{4, 3, std::vector<std::uint8_t>(12, 255)};
  EXPECT_THROW(bad_pixels(kEstimate.view(), small.view(), mask.view()), std::invalid_argument);
  const Map<std::uint8_t> small_mask{2, 2, {255, 255, 255, 255}};
  EXPECT_THROW(bad_pixels(kEstimate.view(), kGroundTruth.view(), small_mask.view()), std::invalid_argument);
}

}  // namespace
}  // namespace mctstereo::app
