// The error map of `eval --save` and the degradation summary of `eval --radiometric`: plain
// functions on float maps, no OpenCV. The scores themselves (Middlebury v2 and v3, KITTI D1, the
// masks, the sparsification curve) are the library's: mctstereo/metrics.hpp.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "mctstereo/image.hpp"
#include "mctstereo/metrics.hpp"

namespace mctstereo::app {

/// The grey level of a pixel without ground truth in the error map: dimmed to this fraction.
inline constexpr double kErrorMapDimming = 0.4;

/// Draws the error map of `estimate` into `bgr` (3 bytes per pixel, B G R; `bgr.width` pixels per
/// row, `bgr.stride` bytes apart): pure red (0, 0, 255) where the ground truth is known and the
/// pixel is bad (|d - gt| > threshold or no estimate); the grey level of `gray` where it is known
/// and good; the grey level times kErrorMapDimming (rounded to nearest) where it is unknown.
void render_error_map(MapView<const float> estimate, MapView<const float> ground_truth,
                      MapView<const std::uint8_t> gray, float threshold, MapView<std::uint8_t> bgr);

/// How much a score (percent bad, lower is better) worsens over the steps of a study.
struct Degradation {
  double baseline = 0.0;           ///< the score of the baseline step
  double worst = 0.0;              ///< the highest score of any step
  std::size_t worst_step = 0;      ///< its index (the first one on a tie)
  double mean = 0.0;               ///< mean score of the steps other than the baseline
  double worst_degradation = 0.0;  ///< worst - baseline, points of percent
  double mean_degradation = 0.0;   ///< mean - baseline, points of percent
};

/// Summarises `scores` (one per step) against `scores[baseline_step]`. With the baseline as the only
/// step, mean is the baseline. std::invalid_argument when baseline_step is out of range.
Degradation summarize_degradation(const std::vector<double>& scores, std::size_t baseline_step);

}  // namespace mctstereo::app
