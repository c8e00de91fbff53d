// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void to_gray(const ImageView& src, Plane<std::uint8_t>& dst) { reference::to_gray(src, dst); }

}  // namespace mctstereo::detail::cpu
