// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void median_filter(const Plane<std::int16_t>& src, int k, Plane<std::int16_t>& dst) { reference::median_filter(src, k, dst); }

}  // namespace mctstereo::detail::cpu
