// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void upscale(const Plane<std::int16_t>& src, int factor, int lo_q4, int hi_q4, Plane<std::int16_t>& dst) { reference::upscale(src, factor, lo_q4, hi_q4, dst); }

}  // namespace mctstereo::detail::cpu
