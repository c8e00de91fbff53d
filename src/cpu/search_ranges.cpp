// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void search_ranges(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius, Plane<std::int16_t>& lo, Plane<std::int16_t>& hi) { reference::search_ranges(coarse, dmin, dmax, radius, lo, hi); }

}  // namespace mctstereo::detail::cpu
