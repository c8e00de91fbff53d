#include <algorithm>

#include "stages.hpp"

namespace mctstereo::detail::reference {

// Invalid pixels (kInvalid, the smallest int16) take part in the median as the smallest value:
// a pixel becomes invalid when more than half of its window is, and a window with a few invalid
// pixels picks a slightly lower (background) value. This keeps the filter a pure order statistic,
// which a SIMD sorting network computes without branches.
void median_filter(const Plane<std::int16_t>& src, int k, Plane<std::int16_t>& dst) {
  const int w = src.width(), h = src.height(), r = k / 2;
  std::int16_t window[25];
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      int n = 0;
      for (int j = -r; j <= r; ++j)
        for (int i = -r; i <= r; ++i) window[n++] = src.at(clamp_index(x + i, w), clamp_index(y + j, h));
      std::nth_element(window, window + n / 2, window + n);
      dst.at(x, y) = window[n / 2];
    }
  }
}

}  // namespace mctstereo::detail::reference
