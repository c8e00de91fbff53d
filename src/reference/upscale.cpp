#include <algorithm>

#include "stages.hpp"

namespace mctstereo::detail::reference {

void upscale(const Plane<std::int16_t>& src, int factor, int lo_q4, int hi_q4,
             Plane<std::int16_t>& dst) {
  for (int y = 0; y < dst.height(); ++y) {
    for (int x = 0; x < dst.width(); ++x) {
      const int v = src.at(x / factor, y / factor);
      dst.at(x, y) = v == kInvalid ? kInvalid
                                   : static_cast<std::int16_t>(std::clamp(v * factor, lo_q4, hi_q4));
    }
  }
}

}  // namespace mctstereo::detail::reference
