#include "eval_metrics.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace mctstereo::app {

namespace {

template <typename A, typename B>
void require_same_size(const MapView<A>& a, const MapView<B>& b, const char* name) {
  if (a.width != b.width || a.height != b.height)
    throw std::invalid_argument(std::string(name) + " is " + std::to_string(b.width) + "x" + std::to_string(b.height) +
                                ", the estimate " + std::to_string(a.width) + "x" + std::to_string(a.height));
}

}  // namespace

RegionScore bad_pixels(MapView<const float> estimate, MapView<const float> ground_truth,
                       MapView<const std::uint8_t> mask, std::uint8_t mask_value, float threshold) {
  require_same_size(estimate, ground_truth, "ground truth");
  require_same_size(estimate, mask, "mask");
  RegionScore score;
  for (int y = 0; y < estimate.height; ++y) {
    const float* d = estimate.row(y);
    const float* gt = ground_truth.row(y);
    const std::uint8_t* m = mask.row(y);
    for (int x = 0; x < estimate.width; ++x) {
      if (m[x] != mask_value || !std::isfinite(gt[x])) continue;
      ++score.pixels;
      // Written so that a NaN estimate fails the comparison and counts as bad.
      if (!(std::isfinite(d[x]) && std::fabs(d[x] - gt[x]) <= threshold)) ++score.bad;
    }
  }
  return score;
}

double density_percent(MapView<const float> estimate) {
  const std::int64_t total = static_cast<std::int64_t>(estimate.width) * estimate.height;
  if (total == 0) return 0.0;
  std::int64_t valid = 0;
  for (int y = 0; y < estimate.height; ++y) {
    const float* d = estimate.row(y);
    for (int x = 0; x < estimate.width; ++x) valid += std::isfinite(d[x]) ? 1 : 0;
  }
  return 100.0 * static_cast<double>(valid) / static_cast<double>(total);
}

MiddleburyV2Score score_middlebury_v2(MapView<const float> estimate, MapView<const float> ground_truth,
                                      MapView<const std::uint8_t> nonocc, MapView<const std::uint8_t> all,
                                      MapView<const std::uint8_t> disc, float threshold) {
  MiddleburyV2Score s;
  s.nonocc = bad_pixels(estimate, ground_truth, nonocc, 255, threshold);
  s.all = bad_pixels(estimate, ground_truth, all, 255, threshold);
  // disc.png marks other non-occluded pixels with 128: only 255 belongs to the region.
  s.disc = bad_pixels(estimate, ground_truth, disc, 255, threshold);
  s.density_percent = density_percent(estimate);
  return s;
}

}  // namespace mctstereo::app
