#include "stages.hpp"

namespace mctstereo::detail::reference {

void to_gray(const ImageView& src, Plane<std::uint8_t>& dst) {
  for (int y = 0; y < src.height; ++y) {
    const std::uint8_t* s = src.row(y);
    std::uint8_t* d = dst.row(y);
    for (int x = 0; x < src.width; ++x) {
      switch (src.format) {
        case PixelFormat::Gray8:
          d[x] = s[x];
          break;
        case PixelFormat::Rgb8:
          d[x] = static_cast<std::uint8_t>((77 * s[3 * x] + 150 * s[3 * x + 1] + 29 * s[3 * x + 2] + 128) >> 8);
          break;
        case PixelFormat::Bgr8:
          d[x] = static_cast<std::uint8_t>((29 * s[3 * x] + 150 * s[3 * x + 1] + 77 * s[3 * x + 2] + 128) >> 8);
          break;
      }
    }
  }
}

}  // namespace mctstereo::detail::reference
