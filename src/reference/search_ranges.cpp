#include "stages.hpp"

namespace mctstereo::detail::reference {

void search_ranges(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius,
                   Plane<std::int16_t>& lo, Plane<std::int16_t>& hi) {
  for (int y = 0; y < lo.height(); ++y) {
    for (int x = 0; x < lo.width(); ++x) {
      const Interval r = search_range_at(coarse, dmin, dmax, radius, x, y);
      lo.at(x, y) = static_cast<std::int16_t>(r.lo);
      hi.at(x, y) = static_cast<std::int16_t>(r.hi);
    }
  }
}

}  // namespace mctstereo::detail::reference
