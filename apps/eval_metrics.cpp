#include "eval_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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

void render_error_map(MapView<const float> estimate, MapView<const float> ground_truth,
                      MapView<const std::uint8_t> gray, float threshold, MapView<std::uint8_t> bgr) {
  require_same_size(estimate, ground_truth, "ground truth");
  require_same_size(estimate, gray, "gray image");
  require_same_size(estimate, bgr, "error map");
  for (int y = 0; y < estimate.height; ++y) {
    const float* d = estimate.row(y);
    const float* gt = ground_truth.row(y);
    const std::uint8_t* g = gray.row(y);
    std::uint8_t* out = bgr.row(y);
    for (int x = 0; x < estimate.width; ++x, out += 3) {
      if (!std::isfinite(gt[x])) {
        const auto dimmed = static_cast<std::uint8_t>(std::lround(g[x] * kErrorMapDimming));
        out[0] = out[1] = out[2] = dimmed;
      } else if (!(std::isfinite(d[x]) && std::fabs(d[x] - gt[x]) <= threshold)) {
        out[0] = 0;
        out[1] = 0;
        out[2] = 255;
      } else {
        out[0] = out[1] = out[2] = g[x];
      }
    }
  }
}

Degradation summarize_degradation(const std::vector<double>& scores, std::size_t baseline_step) {
  if (baseline_step >= scores.size())
    throw std::invalid_argument("baseline step " + std::to_string(baseline_step) + " of " +
                                std::to_string(scores.size()) + " scores");
  Degradation s;
  s.baseline = scores[baseline_step];
  s.worst = scores[0];
  double sum = 0.0;
  for (std::size_t i = 0; i < scores.size(); ++i) {
    if (scores[i] > s.worst) {
      s.worst = scores[i];
      s.worst_step = i;
    }
    if (i != baseline_step) sum += scores[i];
  }
  s.mean = scores.size() > 1 ? sum / static_cast<double>(scores.size() - 1) : s.baseline;
  s.worst_degradation = s.worst - s.baseline;
  s.mean_degradation = s.mean - s.baseline;
  return s;
}

}  // namespace mctstereo::app
