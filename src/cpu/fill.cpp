// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void fill_invalid(Plane<std::int16_t>& disparity, FillMode mode) { reference::fill_invalid(disparity, mode); }

}  // namespace mctstereo::detail::cpu
