// Confidence: a light pass over the map, threaded over rows. The arithmetic is the reference's
// (confidence_agreement()). The quotient a / den, a = margin x agreement <= 255 den, is taken as
// (a M) >> 32 with M = ceil(2^32 / den), which spares a division per pixel. Exact: a M / 2^32
// exceeds a / den by less than a / 2^32 <= 255 x 272 / 2^32 < 2^-15, and a / den is an integer
// or at least 1 / den >= 1 / 272 below the next one.
#include <cstdint>

#include "cpu/parallel.hpp"
#include "stages.hpp"

namespace mctstereo::detail::cpu {

namespace {

// One row. Everything the loop reads is a parameter: the byte stores may alias any memory as far
// as the compiler knows, and through captured references it would reload den, M and the row
// pointers at every pixel.
void confidence_row(const std::int16_t* map, const std::int16_t* right_row, const std::uint8_t* margin, int shift,
                    int w, int den, std::uint64_t magic, std::uint8_t* out) {
  for (int x = 0; x < w; ++x) {
    const int v = map[x];
    if (v == kInvalid) {
      out[x] = 0;
      continue;
    }
    int num = den;
    if (right_row) {
      const int xr = x - ((v + 8) >> 4);
      num = confidence_agreement(v, xr >= 0 && xr < w ? right_row[xr] : kInvalid, den);
    }
    out[x] = static_cast<std::uint8_t>((static_cast<std::uint64_t>(margin[x >> shift] * num) * magic) >> 32);
  }
}

}  // namespace

void confidence(const Plane<std::uint8_t>& margin, int margin_shift, const Plane<std::int16_t>& checked,
                const Plane<std::int16_t>* right, int threshold, Plane<std::uint8_t>& dst) {
  const int w = checked.width(), h = checked.height();
  const int den = 16 * (threshold + 1);
  const auto den64 = static_cast<std::uint64_t>(den);
  const std::uint64_t magic = ((std::uint64_t{1} << 32) + den64 - 1) / den64;
  parallel_lines(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y)
      confidence_row(checked.row(y), right ? right->row(y) : nullptr, margin.row(y >> margin_shift), margin_shift, w,
                     den, magic, dst.row(y));
  });
}

}  // namespace mctstereo::detail::cpu
