#include <algorithm>

#include "stages.hpp"

namespace mctstereo::detail::reference {

void search_ranges(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius,
                   Plane<std::int16_t>& lo, Plane<std::int16_t>& hi) {
  for (int y = 0; y < lo.height(); ++y) {
    for (int x = 0; x < lo.width(); ++x) {
      int range_lo = dmin, range_hi = dmax;
      if (coarse != nullptr) {
        const int cw = coarse->width(), ch = coarse->height();
        const int cx = std::min(x / 2, cw - 1), cy = std::min(y / 2, ch - 1);
        if (coarse->at(cx, cy) != kInvalid) {
          int mn = 1 << 20, mx = -(1 << 20);
          for (int j = -1; j <= 1; ++j) {
            for (int i = -1; i <= 1; ++i) {
              const int v = coarse->at(clamp_index(cx + i, cw), clamp_index(cy + j, ch));
              if (v == kInvalid) continue;
              mn = std::min(mn, v >> 4);  // coarse levels hold whole pixels
              mx = std::max(mx, v >> 4);
            }
          }
          // A prior just outside the level range (2 * ceil(dmax / 2) may be dmax + 1) still
          // leaves at least one candidate.
          range_lo = std::min(std::max(dmin, 2 * mn - radius), dmax);
          range_hi = std::max(std::min(dmax, 2 * mx + radius), dmin);
        }
      }
      lo.at(x, y) = static_cast<std::int16_t>(range_lo);
      hi.at(x, y) = static_cast<std::int16_t>(range_hi);
    }
  }
}

}  // namespace mctstereo::detail::reference
