#include "stages.hpp"

namespace mctstereo::detail::reference {

void split_channels(const ImageView& src, std::array<Plane<std::uint8_t>, 3>& dst) {
  const int channels = bytes_per_pixel(src.format);
  for (int y = 0; y < src.height; ++y) {
    const std::uint8_t* s = src.row(y);
    for (int c = 0; c < channels; ++c) {
      std::uint8_t* d = dst[c].row(y);
      for (int x = 0; x < src.width; ++x) d[x] = s[channels * x + c];
    }
  }
}

}  // namespace mctstereo::detail::reference
