// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void lr_check(const Plane<std::int16_t>& src, const Plane<std::int16_t>& other, int dir, int threshold_q4, Plane<std::int16_t>& dst) { reference::lr_check(src, other, dir, threshold_q4, dst); }

}  // namespace mctstereo::detail::cpu
