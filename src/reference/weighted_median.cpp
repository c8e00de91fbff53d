#include <algorithm>
#include <utility>

#include "stages.hpp"

namespace mctstereo::detail::reference {

// The colour-weighted median as the specification reads: collect the window's (whole disparity,
// weight) samples, sort them by disparity, and walk up until the running weight reaches half the
// total (ceil). Offsets are the multiples of step in [-radius, radius]; coordinates are clamped.
void weighted_median(const Plane<std::int16_t>& src, const ColourPlanes& colour, const WeightedMedianConfig& config,
                     Plane<std::int16_t>& dst) {
  const int w = src.width(), h = src.height();
  const int reach = config.radius / config.step * config.step;
  std::pair<int, int> samples[kMaxWeightedMedianSamples];  // (d, w); a frame allocates nothing
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      int count = 0, total = 0;
      for (int dy = -reach; dy <= reach; dy += config.step) {
        for (int dx = -reach; dx <= reach; dx += config.step) {
          const int qx = clamp_index(x + dx, w), qy = clamp_index(y + dy, h);
          const int v = src.at(qx, qy);
          if (v == kInvalid) continue;  // invalid samples weigh 0
          int k = 0;
          for (int c = 0; c < colour.channels; ++c) {
            const int diff = colour.plane[c]->at(x, y) - colour.plane[c]->at(qx, qy);
            k = std::max(k, diff < 0 ? -diff : diff);
          }
          const int weight = config.lut[k];
          samples[count++] = {q4_to_whole(v), weight};
          total += weight;
        }
      }
      const int own = src.at(x, y);
      if (total == 0) {
        dst.at(x, y) = static_cast<std::int16_t>(own);
        continue;
      }
      std::sort(samples, samples + count);
      const int half = (total + 1) / 2;
      int running = 0, median = 0;
      for (int i = 0; i < count; ++i) {
        const auto [d, weight] = samples[i];
        running += weight;
        if (running >= half) {
          median = d;
          break;
        }
      }
      dst.at(x, y) = own != kInvalid && q4_to_whole(own) == median ? static_cast<std::int16_t>(own)
                                                                    : static_cast<std::int16_t>(16 * median);
    }
  }
}

}  // namespace mctstereo::detail::reference
