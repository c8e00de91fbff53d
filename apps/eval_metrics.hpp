// Middlebury v2 scores of a disparity map: plain functions on float maps and 8-bit masks.
#pragma once

#include <cstdint>

#include "mctstereo/image.hpp"

namespace mctstereo::app {

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

}  // namespace mctstereo::app
