#include "stages.hpp"

namespace mctstereo::detail::reference {

void pyramid_down(const Plane<std::uint8_t>& src, Plane<std::uint8_t>& dst) {
  static constexpr int kWeight[5] = {1, 4, 6, 4, 1};
  const int w = src.width(), h = src.height();
  for (int y = 0; y < dst.height(); ++y) {
    for (int x = 0; x < dst.width(); ++x) {
      int sum = 0;
      for (int j = -2; j <= 2; ++j) {
        for (int i = -2; i <= 2; ++i) {
          const int sx = clamp_index(2 * x + i, w), sy = clamp_index(2 * y + j, h);
          sum += kWeight[i + 2] * kWeight[j + 2] * src.at(sx, sy);
        }
      }
      dst.at(x, y) = static_cast<std::uint8_t>((sum + 128) >> 8);
    }
  }
}

}  // namespace mctstereo::detail::reference
