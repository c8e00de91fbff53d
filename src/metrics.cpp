#include "mctstereo/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace mctstereo {

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

double RegionMetrics::average_error() const {
  const std::int64_t estimated = pixels - invalid;
  return estimated > 0 ? abs_error_sum / static_cast<double>(estimated) : std::numeric_limits<double>::quiet_NaN();
}

double RegionMetrics::rms_error() const {
  const std::int64_t estimated = pixels - invalid;
  return estimated > 0 ? std::sqrt(squared_error_sum / static_cast<double>(estimated))
                       : std::numeric_limits<double>::quiet_NaN();
}

RegionMetrics region_metrics(MapView<const float> estimate, MapView<const float> ground_truth,
                             MapView<const std::uint8_t> mask, std::uint8_t mask_value) {
  require_same_size(estimate, ground_truth, "ground truth");
  require_same_size(estimate, mask, "mask");
  RegionMetrics r;
  for (int y = 0; y < estimate.height; ++y) {
    const float* d = estimate.row(y);
    const float* gt = ground_truth.row(y);
    const std::uint8_t* m = mask.row(y);
    for (int x = 0; x < estimate.width; ++x) {
      if (m[x] != mask_value || !std::isfinite(gt[x])) continue;
      ++r.pixels;
      if (!std::isfinite(d[x])) {
        ++r.invalid;
        for (std::int64_t& b : r.bad) ++b;
        ++r.d1_bad;
        continue;
      }
      // In double: a sum over a few million pixels keeps its precision.
      const double error = std::fabs(static_cast<double>(d[x]) - static_cast<double>(gt[x]));
      for (std::size_t i = 0; i < kV3Thresholds.size(); ++i) r.bad[i] += error > kV3Thresholds[i] ? 1 : 0;
      // KITTI: bad when the error exceeds both 3 px and 5 % of the true disparity.
      r.d1_bad += error > 3.0 && error > 0.05 * std::fabs(static_cast<double>(gt[x])) ? 1 : 0;
      r.abs_error_sum += error;
      r.squared_error_sum += error * error;
    }
  }
  return r;
}

void known_ground_truth_mask(MapView<const float> ground_truth, MapView<std::uint8_t> mask) {
  require_same_size(ground_truth, mask, "mask");
  for (int y = 0; y < ground_truth.height; ++y) {
    const float* gt = ground_truth.row(y);
    std::uint8_t* m = mask.row(y);
    for (int x = 0; x < ground_truth.width; ++x) m[x] = std::isfinite(gt[x]) ? 255 : 0;
  }
}

void lr_check_nonocc_mask(MapView<const float> left_ground_truth, MapView<const float> right_ground_truth,
                          MapView<std::uint8_t> mask, float tolerance) {
  require_same_size(left_ground_truth, right_ground_truth, "right ground truth");
  require_same_size(left_ground_truth, mask, "mask");
  const int w = left_ground_truth.width;
  for (int y = 0; y < left_ground_truth.height; ++y) {
    const float* left = left_ground_truth.row(y);
    const float* right = right_ground_truth.row(y);
    std::uint8_t* m = mask.row(y);
    for (int x = 0; x < w; ++x) {
      m[x] = 0;
      if (!std::isfinite(left[x])) continue;
      // In double before rounding: a huge disparity must not overflow the match column.
      const double xr = static_cast<double>(x) - std::round(static_cast<double>(left[x]));
      if (!(xr >= 0.0 && xr < w)) continue;
      const float dr = right[static_cast<int>(xr)];
      if (std::isfinite(dr) && std::fabs(left[x] - dr) <= tolerance) m[x] = 255;
    }
  }
}

std::array<double, 4> sparsification_curve(MapView<const float> estimate, MapView<const float> ground_truth,
                                           MapView<const float> confidence, MapView<const std::uint8_t> mask,
                                           std::uint8_t mask_value, float threshold) {
  require_same_size(estimate, ground_truth, "ground truth");
  require_same_size(estimate, confidence, "confidence");
  require_same_size(estimate, mask, "mask");
  struct Pixel {
    float confidence;
    bool bad;
  };
  std::vector<Pixel> pixels;
  for (int y = 0; y < estimate.height; ++y)
    for (int x = 0; x < estimate.width; ++x) {
      const float gt = ground_truth.at(x, y);
      if (mask.at(x, y) != mask_value || !std::isfinite(gt)) continue;
      const float e = estimate.at(x, y);
      pixels.push_back({confidence.at(x, y), !std::isfinite(e) || std::fabs(e - gt) > threshold});
    }
  std::stable_sort(pixels.begin(), pixels.end(),
                   [](const Pixel& a, const Pixel& b) { return a.confidence > b.confidence; });
  std::array<double, 4> curve{};
  for (std::size_t i = 0; i < curve.size(); ++i) {
    const auto kept = static_cast<std::size_t>(std::ceil(kSparsificationFractions[i] * pixels.size() - 1e-9));
    std::size_t bad = 0;
    for (std::size_t p = 0; p < kept; ++p) bad += pixels[p].bad;
    curve[i] = kept == 0 ? std::numeric_limits<double>::quiet_NaN() : 100.0 * bad / kept;
  }
  return curve;
}

}  // namespace mctstereo
