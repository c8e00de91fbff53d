#include <algorithm>

#include "stages.hpp"

namespace mctstereo::detail::reference {

void fill_invalid(Plane<std::int16_t>& disparity, FillMode mode) {
  if (mode == FillMode::None) return;
  const int w = disparity.width();
  for (int y = 0; y < disparity.height(); ++y) {
    std::int16_t* row = disparity.row(y);
    for (int x = 0; x < w;) {
      if (row[x] != kInvalid) {
        ++x;
        continue;
      }
      // A run of invalid pixels [x, end): both neighbours are original valid values.
      int end = x;
      while (end < w && row[end] == kInvalid) ++end;
      const bool has_left = x > 0, has_right = end < w;
      if (has_left || has_right) {
        const std::int16_t left = has_left ? row[x - 1] : kInvalid;
        const std::int16_t right = has_right ? row[end] : kInvalid;
        for (int i = x; i < end; ++i) {
          std::int16_t v;
          if (!has_left) v = right;
          else if (!has_right) v = left;
          else if (mode == FillMode::NearestLower) v = std::min(left, right);
          else {
            const int dl = i - (x - 1), dr = end - i;
            v = dl < dr ? left : (dr < dl ? right : std::min(left, right));
          }
          row[i] = v;
        }
      }
      x = end;
    }
  }
}

}  // namespace mctstereo::detail::reference
