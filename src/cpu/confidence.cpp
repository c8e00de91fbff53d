// Confidence: a light pass over the map, threaded over rows. The arithmetic is the reference's
// (confidence_agreement()); the quotient margin x agreement / den of integers below 2^24 is taken
// in double, exact after truncation (see sgm_margin_fast()), which spares an integer division per
// pixel.
#include "cpu/parallel.hpp"
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void confidence(const Plane<std::uint8_t>& margin, int margin_shift, const Plane<std::int16_t>& checked,
                const Plane<std::int16_t>* right, int threshold, Plane<std::uint8_t>& dst) {
  const int w = checked.width(), h = checked.height();
  const int den = 16 * (threshold + 1);
  parallel_lines(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const std::int16_t* map = checked.row(y);
      const std::int16_t* right_row = right ? right->row(y) : nullptr;
      const std::uint8_t* m = margin.row(y >> margin_shift);
      std::uint8_t* out = dst.row(y);
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
        out[x] = static_cast<std::uint8_t>(static_cast<double>(m[x >> margin_shift] * num) / den);
      }
    }
  });
}

}  // namespace mctstereo::detail::cpu
