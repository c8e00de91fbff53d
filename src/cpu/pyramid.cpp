// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void pyramid_down(const Plane<std::uint8_t>& src, Plane<std::uint8_t>& dst) { reference::pyramid_down(src, dst); }

}  // namespace mctstereo::detail::cpu
