// mctstereo: scores of a disparity map against ground truth (Middlebury v2 and v3, KITTI D1), the
// masks a scene without mask files gets, and the sparsification curve of a confidence map: plain
// functions on float maps and 8-bit masks.
//
// Conventions shared by every function here: a ground truth that is not finite (NaN, +INF) is
// unknown and its pixel is left out; an estimate that is not finite is a pixel without a
// disparity. All maps passed together must have the same size (std::invalid_argument otherwise).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "mctstereo/image.hpp"

namespace mctstereo {

/// Bad pixels of one region.
struct RegionScore {
  std::int64_t pixels = 0;  ///< pixels of the region with a known ground truth
  std::int64_t bad = 0;     ///< of those, the bad ones
  /// 100 * bad / pixels; 0 for an empty region.
  double percent() const { return pixels > 0 ? 100.0 * static_cast<double>(bad) / static_cast<double>(pixels) : 0.0; }
};

/// The three regions of the Middlebury v2 evaluation and the density of the map.
struct MiddleburyV2Score {
  RegionScore nonocc;  ///< non-occluded pixels (nonocc mask == 255)
  RegionScore all;     ///< every pixel with ground truth (all mask == 255)
  RegionScore disc;    ///< non-occluded pixels near depth discontinuities (disc mask == 255 only)
  double density_percent = 0.0;  ///< 100 * valid estimates / all pixels of the map
};

/// Counts the bad pixels of `estimate` among the pixels where `mask` equals `mask_value` and the
/// ground truth is known. A pixel is bad when |estimate - gt| > threshold, or when the estimate is
/// not finite (NaN or infinite: no disparity counts as a wrong one). A ground truth that is not
/// finite (NaN) is unknown and the pixel is left out. All three maps must have the same size.
RegionScore bad_pixels(MapView<const float> estimate, MapView<const float> ground_truth,
                       MapView<const std::uint8_t> mask, std::uint8_t mask_value = 255, float threshold = 1.0f);

/// 100 * (pixels of `estimate` with a finite value) / (all its pixels).
double density_percent(MapView<const float> estimate);

/// The Middlebury v2 scores: bad pixels (> threshold) in the nonocc, all and disc masks (== 255).
MiddleburyV2Score score_middlebury_v2(MapView<const float> estimate, MapView<const float> ground_truth,
                                      MapView<const std::uint8_t> nonocc, MapView<const std::uint8_t> all,
                                      MapView<const std::uint8_t> disc, float threshold = 1.0f);

/// The bad-pixel thresholds of the Middlebury v3 table, pixels: bad 0.5, bad 1, bad 2, bad 4.
inline constexpr std::array<float, 4> kV3Thresholds = {0.5f, 1.0f, 2.0f, 4.0f};

/// Middlebury v3 and KITTI D1 metrics of one region. Pixels without an estimate count as bad in
/// the bad-N and D1 rates; they are left out of the average and RMS errors, which describe the
/// estimates that exist, and counted on their own as `invalid`.
struct RegionMetrics {
  std::int64_t pixels = 0;   ///< pixels of the region with a known ground truth
  std::int64_t invalid = 0;  ///< of those, the pixels without an estimate
  std::array<std::int64_t, kV3Thresholds.size()> bad{};  ///< |d - gt| > kV3Thresholds[i], or no estimate
  std::int64_t d1_bad = 0;  ///< KITTI D1: |d - gt| > 3 px and > 5 % of |gt|, or no estimate
  double abs_error_sum = 0.0;      ///< sum of |d - gt| over the pixels with an estimate
  double squared_error_sum = 0.0;  ///< sum of (d - gt)^2 over the pixels with an estimate

  /// 100 * bad[i] / pixels; 0 for an empty region.
  double bad_percent(std::size_t i) const { return percent_of(bad[i]); }
  double d1_percent() const { return percent_of(d1_bad); }
  double invalid_percent() const { return percent_of(invalid); }
  /// Mean |d - gt| over the pixels with an estimate, pixels; NaN when no pixel has one.
  double average_error() const;
  /// sqrt(mean (d - gt)^2) over the pixels with an estimate, pixels; NaN when no pixel has one.
  double rms_error() const;

 private:
  double percent_of(std::int64_t n) const {
    return pixels > 0 ? 100.0 * static_cast<double>(n) / static_cast<double>(pixels) : 0.0;
  }
};

/// The Middlebury v3 and D1 metrics of `estimate` over the pixels where `mask` equals
/// `mask_value` and the ground truth is known.
RegionMetrics region_metrics(MapView<const float> estimate, MapView<const float> ground_truth,
                             MapView<const std::uint8_t> mask, std::uint8_t mask_value = 255);

/// Writes 255 into `mask` where the ground truth is known, 0 elsewhere: the "all" region of a
/// scene that has no mask file for it.
void known_ground_truth_mask(MapView<const float> ground_truth, MapView<std::uint8_t> mask);

/// The non-occluded region of a scene with ground truth for both views (Middlebury 2005/2006),
/// by the left-right check of the two ground truths. Writes 255 into `mask` at a left pixel (x, y)
/// whose ground truth d is known when its match x_r = x - lround(d) (rounded half away from zero)
/// lies inside the image, the right view's ground truth d_r at (x_r, y) is known, and
/// |d - d_r| <= `tolerance`; 0 elsewhere. Right ground truth follows the right view's convention:
/// the right pixel x_r matches the left pixel x_r + d_r.
void lr_check_nonocc_mask(MapView<const float> left_ground_truth, MapView<const float> right_ground_truth,
                          MapView<std::uint8_t> mask, float tolerance = 1.0f);

/// The fractions of the sparsification curve: the most confident 100, 90, 75 and 50 % of the pixels.
inline constexpr std::array<double, 4> kSparsificationFractions = {1.0, 0.9, 0.75, 0.5};

/// The sparsification curve of a confidence map: for each fraction f of kSparsificationFractions,
/// the percent of bad pixels (|estimate - gt| > threshold, or no estimate) among the ceil(f n) most
/// confident of the n pixels where `mask` equals `mask_value` and the ground truth is known (ties in
/// confidence keep row order). NaN entries when n = 0. A useful confidence gives a falling curve.
std::array<double, 4> sparsification_curve(MapView<const float> estimate, MapView<const float> ground_truth,
                                           MapView<const float> confidence, MapView<const std::uint8_t> mask,
                                           std::uint8_t mask_value, float threshold);

}  // namespace mctstereo
