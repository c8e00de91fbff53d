#include "stages.hpp"

namespace mctstereo::detail::reference {

void output_q4(const Plane<std::int16_t>& src, std::int16_t invalid_q4, Plane<std::int16_t>& dst) {
  for (int y = 0; y < dst.height(); ++y)
    for (int x = 0; x < dst.width(); ++x) dst.at(x, y) = src.at(x, y) == kInvalid ? invalid_q4 : src.at(x, y);
}

}  // namespace mctstereo::detail::reference
