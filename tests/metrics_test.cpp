// The metrics of the library (Middlebury v2 and v3, KITTI D1), the masks it derives and the
// sparsification curve, on small maps whose answers are counted by hand.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "hand_counted_maps.hpp"
#include "mctstereo/metrics.hpp"

namespace mctstereo {
namespace {

using namespace test;  // kNaN, kInf, Map, kGroundTruth, kEstimate

TEST(Metrics, BadPixelsOverTheWholeMaskCountInvalidAsBadAndSkipUnknownTruth) {
  const Map<std::uint8_t> all{4, 3, std::vector<std::uint8_t>(12, 255)};
  const RegionScore s = bad_pixels(kEstimate.view(), kGroundTruth.view(), all.view());
  EXPECT_EQ(s.pixels, 11);  // 12 minus the unknown ground truth
  EXPECT_EQ(s.bad, 4);      // (2,0), (0,1) NaN, (3,1) INF, (1,2)
  EXPECT_DOUBLE_EQ(s.percent(), 100.0 * 4 / 11);
}

TEST(Metrics, BadPixelsOnlyCountTheMaskValue) {
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

TEST(Metrics, ThresholdIsStrict) {
  const Map<std::uint8_t> all{4, 3, std::vector<std::uint8_t>(12, 255)};
  // At 0.5 px the 1-px error of (1,0) and 0.25-px error of (2,2): only the first turns bad.
  EXPECT_EQ(bad_pixels(kEstimate.view(), kGroundTruth.view(), all.view(), 255, 0.5f).bad, 5);
  // At 3 px only the invalid pixels stay bad: an error of exactly 3 is not above the threshold.
  EXPECT_EQ(bad_pixels(kEstimate.view(), kGroundTruth.view(), all.view(), 255, 3.0f).bad, 2);
}

TEST(Metrics, EmptyRegionScoresZero) {
  const Map<std::uint8_t> none{4, 3, std::vector<std::uint8_t>(12, 0)};
  const RegionScore s = bad_pixels(kEstimate.view(), kGroundTruth.view(), none.view());
  EXPECT_EQ(s.pixels, 0);
  EXPECT_EQ(s.percent(), 0.0);
}

TEST(Metrics, DensityIsThePercentOfFiniteEstimates) {
  EXPECT_DOUBLE_EQ(density_percent(kEstimate.view()), 100.0 * 10 / 12);
  const Map<float> all_invalid{2, 2, {kNaN, kInf, -kInf, kNaN}};
  EXPECT_EQ(density_percent(all_invalid.view()), 0.0);
}

TEST(Metrics, MiddleburyV2ScoresEachMask) {
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

TEST(Metrics, MapsOfDifferentSizesAreRejected) {
  const Map<float> small{2, 2, {1, 1, 1, 1}};
  const Map<std::uint8_t> mask{4, 3, std::vector<std::uint8_t>(12, 255)};
  EXPECT_THROW(bad_pixels(kEstimate.view(), small.view(), mask.view()), std::invalid_argument);
  const Map<std::uint8_t> small_mask{2, 2, {255, 255, 255, 255}};
  EXPECT_THROW(bad_pixels(kEstimate.view(), kGroundTruth.view(), small_mask.view()), std::invalid_argument);
}

const Map<std::uint8_t> kWholeMask{4, 3, std::vector<std::uint8_t>(12, 255)};

TEST(Metrics, V3MetricsCountInvalidAsBadAndLeaveThemOutOfTheErrors) {
  const RegionMetrics m = region_metrics(kEstimate.view(), kGroundTruth.view(), kWholeMask.view());
  EXPECT_EQ(m.pixels, 11);  // the unknown ground truth at (3,0) is left out
  EXPECT_EQ(m.invalid, 2);  // (0,1) NaN, (3,1) +INF
  // Errors of the 9 estimates: 0, 1, 1.5, 0, 0, 0, 3, 0.25, 0; each rate adds the 2 invalid pixels.
  EXPECT_EQ(m.bad[0], 3 + 2);  // > 0.5: 1, 1.5, 3
  EXPECT_EQ(m.bad[1], 2 + 2);  // > 1: 1.5, 3
  EXPECT_EQ(m.bad[2], 1 + 2);  // > 2: 3
  EXPECT_EQ(m.bad[3], 0 + 2);  // > 4: none
  EXPECT_DOUBLE_EQ(m.bad_percent(1), 100.0 * 4 / 11);
  EXPECT_DOUBLE_EQ(m.invalid_percent(), 100.0 * 2 / 11);
  EXPECT_DOUBLE_EQ(m.average_error(), 5.75 / 9);            // 1 + 1.5 + 3 + 0.25
  EXPECT_DOUBLE_EQ(m.rms_error(), std::sqrt(12.3125 / 9));  // 1 + 2.25 + 9 + 0.0625
  EXPECT_EQ(m.d1_bad, 2);  // the error of 3 px is not above 3 px: only the invalid pixels
  // Bad 1 of v3 is the v2 rate at the default threshold.
  EXPECT_EQ(m.bad[1], bad_pixels(kEstimate.view(), kGroundTruth.view(), kWholeMask.view()).bad);
}

TEST(Metrics, V3MetricsOnlyCountTheMaskValue) {
  const Map<std::uint8_t> mask{4, 3, {255, 0, 255, 255,  //
                                      0, 0, 0, 255,      //
                                      0, 255, 0, 0}};
  // (0,0) error 0, (2,0) error 1.5, (3,0) unknown, (3,1) invalid, (1,2) error 3.
  const RegionMetrics m = region_metrics(kEstimate.view(), kGroundTruth.view(), mask.view());
  EXPECT_EQ(m.pixels, 4);
  EXPECT_EQ(m.invalid, 1);
  EXPECT_EQ(m.bad[0], 3);
  EXPECT_EQ(m.bad[3], 1);
  EXPECT_DOUBLE_EQ(m.average_error(), 4.5 / 3);
}

TEST(Metrics, D1NeedsMoreThan3PixelsAndMoreThan5Percent) {
  const Map<float> gt{5, 1, {100, 100, 10, 2, 0}};
  const Map<float> estimate{5, 1, {103.5f,  // 3.5 px but 3.5 %: good
                                   106,     // 6 px and 6 %: bad
                                   13.5f,   // 3.5 px and 35 %: bad
                                   4.9f,    // 145 % but 2.9 px: good
                                   3.5f}};  // 3.5 px of a true 0: bad
  const Map<std::uint8_t> mask{5, 1, std::vector<std::uint8_t>(5, 255)};
  const RegionMetrics m = region_metrics(estimate.view(), gt.view(), mask.view());
  EXPECT_EQ(m.d1_bad, 3);
  EXPECT_DOUBLE_EQ(m.d1_percent(), 60.0);
  EXPECT_EQ(m.bad[3], 1);  // > 4 px: only the 6 px error
}

TEST(Metrics, EmptyRegionHasNoErrors) {
  const Map<std::uint8_t> none{4, 3, std::vector<std::uint8_t>(12, 0)};
  const RegionMetrics m = region_metrics(kEstimate.view(), kGroundTruth.view(), none.view());
  EXPECT_EQ(m.pixels, 0);
  EXPECT_EQ(m.bad_percent(0), 0.0);
  EXPECT_EQ(m.d1_percent(), 0.0);
  EXPECT_TRUE(std::isnan(m.average_error()));
  EXPECT_TRUE(std::isnan(m.rms_error()));
  // Every pixel of a region without a single estimate: rates 100 %, no average error.
  const Map<float> nothing{4, 3, std::vector<float>(12, kNaN)};
  const RegionMetrics all_invalid = region_metrics(nothing.view(), kGroundTruth.view(), kWholeMask.view());
  EXPECT_DOUBLE_EQ(all_invalid.bad_percent(0), 100.0);
  EXPECT_DOUBLE_EQ(all_invalid.invalid_percent(), 100.0);
  EXPECT_TRUE(std::isnan(all_invalid.average_error()));
}

TEST(Metrics, KnownGroundTruthMaskIsTheAllRegion) {
  Map<std::uint8_t> mask{4, 3, std::vector<std::uint8_t>(12, 7)};
  known_ground_truth_mask(kGroundTruth.view(), {mask.values.data(), 4, 3, 4});
  EXPECT_EQ(mask.values, (std::vector<std::uint8_t>{255, 255, 255, 0, 255, 255, 255, 255, 255, 255, 255, 255}));
}

TEST(Metrics, LeftRightCheckOfTwoGroundTruthsFindsTheNonOccludedPixels) {
  // Row 0, left pixel x with ground truth d looks at the right ground truth at x - round(d):
  //   x=0 unknown; x=1 d=1 -> right[0]=1 agrees; x=2 d=3 -> column -1, outside;
  //   x=3 d=3 -> right[0]=1, 2 px apart (occluded); x=4 d=2 -> right[2] unknown;
  //   x=5 d=1.5 -> round 2 -> right[3]=2.5, exactly 1 px apart (kept);
  //   x=6 d=2.5 -> round half away from zero 3 -> right[3]=2.5 (round to even would give
  //   right[4]=0.5, 2 px apart); x=7 d=1 -> right[6]=1.
  // Row 1: negative disparities look right: x=0 d=-1 -> right[1]=-1; x=7 d=-1 -> column 8,
  // outside; x=3 a huge disparity lands far outside.
  const Map<float> left{8, 2, {kNaN, 1, 3, 3, 2, 1.5f, 2.5f, 1,  //
                               -1, kNaN, kNaN, 1e30f, kNaN, kNaN, kNaN, -1}};
  const Map<float> right{8, 2, {1, 5, kNaN, 2.5f, 0.5f, 7, 1, 9,  //
                                kNaN, -1, kNaN, kNaN, kNaN, kNaN, kNaN, kNaN}};
  Map<std::uint8_t> mask{8, 2, std::vector<std::uint8_t>(16, 7)};
  lr_check_nonocc_mask(left.view(), right.view(), {mask.values.data(), 8, 2, 8});
  EXPECT_EQ(mask.values, (std::vector<std::uint8_t>{0, 255, 0, 0, 0, 255, 255, 255,  //
                                                    255, 0, 0, 0, 0, 0, 0, 0}));
  // A tighter tolerance drops the pixel 1 px apart.
  lr_check_nonocc_mask(left.view(), right.view(), {mask.values.data(), 8, 2, 8}, 0.5f);
  EXPECT_EQ(mask.values[5], 0);
  EXPECT_EQ(mask.values[6], 255);
}

TEST(Metrics, V3MetricsAndMasksRejectMapsOfOtherSizes) {
  const Map<float> small{2, 2, {1, 1, 1, 1}};
  const Map<std::uint8_t> small_mask{2, 2, {255, 255, 255, 255}};
  EXPECT_THROW(region_metrics(kEstimate.view(), small.view(), kWholeMask.view()), std::invalid_argument);
  EXPECT_THROW(region_metrics(kEstimate.view(), kGroundTruth.view(), small_mask.view()), std::invalid_argument);
  std::vector<std::uint8_t> out(12);
  EXPECT_THROW(lr_check_nonocc_mask(kGroundTruth.view(), small.view(), {out.data(), 4, 3, 4}), std::invalid_argument);
  EXPECT_THROW(known_ground_truth_mask(kGroundTruth.view(), {out.data(), 2, 2, 2}), std::invalid_argument);
}

// Eight pixels with ground truth (one unknown, one outside the mask): ranked by confidence, the
// curve drops as the bad ones sit at low confidence.
TEST(Metrics, SparsificationCurveRanksByConfidence) {
  const Map<float> gt{5, 2, {1, 1, 1, 1, 1,  //
                             1, 1, 1, kNaN, 1}};
  const Map<float> est{5, 2, {1, 5, 1, 1, kNaN,  //
                              1, 1, 3, 1, 1}};
  // Bad: (1, 0) and (2, 1) (off by 4 and 2) and (4, 0) (no estimate); (3, 1) has no truth.
  const Map<float> conf{5, 2, {0.9f, 0.1f, 0.8f, 0.7f, 0.0f,  //
                               0.6f, 0.5f, 0.2f, 1.0f, 0.3f}};
  Map<std::uint8_t> mask{5, 2, std::vector<std::uint8_t>(10, 255)};
  mask.values[9] = 0;  // (4, 1) is outside the region
  const auto c = sparsification_curve(est.view(), gt.view(), conf.view(), mask.view(), 255, 1.0f);
  // 8 pixels, 3 bad: 100 % -> 3 / 8; 90 % -> ceil(7.2) = 8 -> 3 / 8; 75 % -> 6 most confident
  // (0.9, 0.8, 0.7, 0.6, 0.5, 0.2): 1 bad; 50 % -> 4 (0.9, 0.8, 0.7, 0.6): none.
  EXPECT_DOUBLE_EQ(c[0], 100.0 * 3 / 8);
  EXPECT_DOUBLE_EQ(c[1], 100.0 * 3 / 8);
  EXPECT_DOUBLE_EQ(c[2], 100.0 * 1 / 6);
  EXPECT_DOUBLE_EQ(c[3], 0.0);
  const Map<std::uint8_t> none{5, 2, std::vector<std::uint8_t>(10, 0)};
  EXPECT_TRUE(std::isnan(sparsification_curve(est.view(), gt.view(), conf.view(), none.view(), 255, 1.0f)[0]));
}

}  // namespace
}  // namespace mctstereo
