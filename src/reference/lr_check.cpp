#include <cstdlib>

#include "stages.hpp"

namespace mctstereo::detail::reference {

void lr_check(const Plane<std::int16_t>& src, const Plane<std::int16_t>& other, int dir,
              int threshold_q4, Plane<std::int16_t>& dst) {
  const int w = src.width(), h = src.height();
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int v = src.at(x, y);
      std::int16_t out = kInvalid;
      if (v != kInvalid) {
        const int xo = x + dir * ((v + 8) >> 4);  // matching pixel at the rounded disparity
        if (xo >= 0 && xo < w) {
          const int o = other.at(xo, y);
          if (o != kInvalid && std::abs(v - o) <= threshold_q4) out = static_cast<std::int16_t>(v);
        }
      }
      dst.at(x, y) = out;
    }
  }
}

}  // namespace mctstereo::detail::reference
