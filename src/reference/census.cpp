#include "stages.hpp"

namespace mctstereo::detail::reference {

void census_transform(const Plane<std::uint8_t>& image, const CensusConfig& config,
                      CensusCodes& codes) {
  const int w = image.width(), h = image.height();
  const int r = config.window / 2;
  const int bits = config.window * config.window - 1;
  const int* kernel = nullptr;
  static constexpr int kBox[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1};
  static constexpr int kGauss[9] = {1, 2, 1, 2, 4, 2, 1, 2, 1};
  kernel = config.kernel == MeanKernel::Box ? kBox : kGauss;
  const int norm = config.kernel == MeanKernel::Box ? 9 : 16;
  auto pixel = [&](int x, int y) { return static_cast<int>(image.at(clamp_index(x, w), clamp_index(y, h))); };

  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      // CT compares I(P') with I(P); MCT compares I(P') * norm with the weighted 3x3 sum S(P),
      // which is the mean test without any rounding.
      int centre_scaled, scale;
      if (config.kind == CensusKind::Census) {
        centre_scaled = pixel(x, y);
        scale = 1;
      } else {
        int s = 0;
        for (int j = -1; j <= 1; ++j)
          for (int i = -1; i <= 1; ++i) s += kernel[(j + 1) * 3 + (i + 1)] * pixel(x + i, y + j);
        centre_scaled = s;
        scale = norm;
      }
      // Bit b (0 = first neighbour in row-major order) lands at string position b; position 0 is
      // the most significant bit of the whole string. Word k holds positions 32k .. 32k + 31, the
      // last word right-aligned: a 24-bit string occupies bits 23..0 of word 0.
      std::uint32_t word[3] = {0, 0, 0};
      int b = 0;
      for (int j = -r; j <= r; ++j) {
        for (int i = -r; i <= r; ++i) {
          if (i == 0 && j == 0) continue;
          const std::uint32_t bit = pixel(x + i, y + j) * scale < centre_scaled ? 1u : 0u;
          const int k = b / 32;
          const int bits_in_word = (k == (bits - 1) / 32) ? bits - 32 * k : 32;
          word[k] |= bit << (bits_in_word - 1 - (b % 32));
          ++b;
        }
      }
      for (int k = 0; k < codes.words; ++k) codes.plane[k].at(x, y) = word[k];
    }
  }
  for (int k = 0; k < codes.words; ++k) codes.plane[k].replicate_pad();
}

}  // namespace mctstereo::detail::reference
