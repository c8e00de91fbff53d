#include <algorithm>
#include <array>

#include "stages.hpp"

namespace mctstereo::detail::reference {

// Each partner straight from its definition: the k x k samples of the grid around (x / 2, y / 2),
// taken from the right map at twice their grid coordinates, and their median (invalid pixels are
// INT16_MIN, so they enter as the smallest value, as in median_filter()).
void grid_partner(const Plane<std::int16_t>& right, int median_size, MatchScratch& /*scratch*/,
                  Plane<std::int16_t>& partner) {
  const int w = right.width(), h = right.height();
  const int gw = (w + 1) / 2, gh = (h + 1) / 2, r = median_size / 2;
  std::array<std::int16_t, 25> window{};
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      int n = 0;
      for (int b = -r; b <= r; ++b)
        for (int a = -r; a <= r; ++a)
          window[n++] = right.at(2 * clamp_index(x / 2 + a, gw), 2 * clamp_index(y / 2 + b, gh));
      std::nth_element(window.begin(), window.begin() + n / 2, window.begin() + n);
      partner.at(x, y) = window[n / 2];
    }
  }
}

std::size_t grid_partner_scratch_bytes(int /*width*/) { return 0; }

}  // namespace mctstereo::detail::reference
