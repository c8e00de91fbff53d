// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void remove_speckles(Plane<std::int16_t>& disparity, int max_size, int max_diff_q4, SpeckleScratch& scratch) { reference::remove_speckles(disparity, max_size, max_diff_q4, scratch); }

}  // namespace mctstereo::detail::cpu
