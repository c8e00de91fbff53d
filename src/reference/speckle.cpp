#include <cstdlib>

#include "stages.hpp"

namespace mctstereo::detail::reference {

// One label per pixel.
int speckle_label_width(int width) { return width; }

void remove_speckles(Plane<std::int16_t>& disparity, int max_size, int max_diff_q4,
                     SpeckleScratch& scratch) {
  const int w = disparity.width(), h = disparity.height();
  Plane<std::int32_t>& label = scratch.label;
  std::int32_t* stack = scratch.stack.get();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) label.at(x, y) = 0;

  int next_label = 0;
  for (int y0 = 0; y0 < h; ++y0) {
    for (int x0 = 0; x0 < w; ++x0) {
      if (disparity.at(x0, y0) == kInvalid || label.at(x0, y0) != 0) continue;
      // Flood fill; the stack keeps every pixel of the region, so a small one can be erased.
      ++next_label;
      int size = 0, top = 0;
      stack[size++] = y0 * w + x0;
      label.at(x0, y0) = next_label;
      while (top < size) {
        const int p = stack[top++];
        const int x = p % w, y = p / w;
        const int v = disparity.at(x, y);
        const int nx[4] = {x - 1, x + 1, x, x};
        const int ny[4] = {y, y, y - 1, y + 1};
        for (int n = 0; n < 4; ++n) {
          if (nx[n] < 0 || nx[n] >= w || ny[n] < 0 || ny[n] >= h) continue;
          const int u = disparity.at(nx[n], ny[n]);
          if (u == kInvalid || label.at(nx[n], ny[n]) != 0 || std::abs(u - v) > max_diff_q4) continue;
          label.at(nx[n], ny[n]) = next_label;
          stack[size++] = ny[n] * w + nx[n];
        }
      }
      if (size < max_size)
        for (int i = 0; i < size; ++i) disparity.at(stack[i] % w, stack[i] / w) = kInvalid;
    }
  }
}

}  // namespace mctstereo::detail::reference
