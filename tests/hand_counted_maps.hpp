// Small maps whose metrics are counted by hand, shared by the tests of the library's metrics
// (tests/metrics_test.cpp) and of eval's error map (tests/apps/eval_metrics_test.cpp).
#pragma once

#include <limits>
#include <vector>

#include "mctstereo/image.hpp"

namespace mctstereo::test {

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

}  // namespace mctstereo::test
