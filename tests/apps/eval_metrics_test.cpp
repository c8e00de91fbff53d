// The error map and the degradation summary of `mctstereo eval` on small maps whose answers are
// counted by hand (the metrics themselves: tests/metrics_test.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "../hand_counted_maps.hpp"
#include "eval_metrics.hpp"

namespace mctstereo::app {
namespace {

using namespace test;  // kNaN, kInf, Map, kGroundTruth, kEstimate

TEST(EvalMetrics, ErrorMapPaintsBadPixelsRedAndDimsUnknownTruth) {
  const Map<std::uint8_t> gray{4, 3, {10, 20, 30, 40,  //
                                      50, 60, 70, 80,  //
                                      90, 100, 110, 200}};
  std::vector<std::uint8_t> bgr(4 * 3 * 3, 1);
  render_error_map(kEstimate.view(), kGroundTruth.view(), gray.view(), 1.0f, {bgr.data(), 4, 3, 12});
  const auto pixel = [&](int x, int y) {
    const std::size_t at = static_cast<std::size_t>(y) * 12 + 3 * x;
    return std::vector<int>{bgr[at], bgr[at + 1], bgr[at + 2]};
  };
  const std::vector<int> red{0, 0, 255};
  EXPECT_EQ(pixel(0, 0), (std::vector<int>{10, 10, 10}));  // exact
  EXPECT_EQ(pixel(1, 0), (std::vector<int>{20, 20, 20}));  // error 1: not above the threshold
  EXPECT_EQ(pixel(2, 0), red);                             // error 1.5
  EXPECT_EQ(pixel(3, 0), (std::vector<int>{16, 16, 16}));  // unknown truth: 40 * 0.4
  EXPECT_EQ(pixel(0, 1), red);                             // no estimate
  EXPECT_EQ(pixel(3, 1), red);                             // no estimate (+INF)
  EXPECT_EQ(pixel(1, 2), red);                             // error 3
  EXPECT_EQ(pixel(3, 2), (std::vector<int>{200, 200, 200}));
  // A looser threshold turns the 1.5 px error grey.
  render_error_map(kEstimate.view(), kGroundTruth.view(), gray.view(), 2.0f, {bgr.data(), 4, 3, 12});
  EXPECT_EQ(pixel(2, 0), (std::vector<int>{30, 30, 30}));
  EXPECT_EQ(pixel(1, 2), red);
}

TEST(EvalMetrics, DegradationAgainstTheBaselineStep) {
  const Degradation d = summarize_degradation({10, 12, 9, 15, 11, 15}, 0);
  EXPECT_EQ(d.baseline, 10);
  EXPECT_EQ(d.worst, 15);
  EXPECT_EQ(d.worst_step, 3u);  // the first of the two 15s
  EXPECT_DOUBLE_EQ(d.mean, (12 + 9 + 15 + 11 + 15) / 5.0);
  EXPECT_DOUBLE_EQ(d.worst_degradation, 5);
  EXPECT_DOUBLE_EQ(d.mean_degradation, 12.4 - 10);
  // The baseline need not come first, and a study that only improves has a negative mean.
  const Degradation better = summarize_degradation({8, 9, 7}, 1);
  EXPECT_EQ(better.worst, 9);
  EXPECT_EQ(better.worst_step, 1u);
  EXPECT_DOUBLE_EQ(better.mean_degradation, 7.5 - 9);
  const Degradation alone = summarize_degradation({7}, 0);
  EXPECT_EQ(alone.mean, 7);
  EXPECT_EQ(alone.mean_degradation, 0);
  EXPECT_THROW(summarize_degradation({1, 2}, 2), std::invalid_argument);
}

TEST(EvalMetrics, ErrorMapRejectsMapsOfOtherSizes) {
  const Map<std::uint8_t> small_mask{2, 2, {255, 255, 255, 255}};
  std::vector<std::uint8_t> bgr(36);
  EXPECT_THROW(render_error_map(kEstimate.view(), kGroundTruth.view(), small_mask.view(), 1.0f, {bgr.data(), 4, 3, 12}),
               std::invalid_argument);
}

}  // namespace
}  // namespace mctstereo::app
