// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

std::size_t match_scratch_bytes(int width, int max_range, int shd_window) { return reference::match_scratch_bytes(width, max_range, shd_window); }
void match(const CensusCodes& ref, const CensusCodes& other, const Plane<std::int16_t>& lo, const Plane<std::int16_t>& hi, const MatchConfig& config, MatchScratch& scratch, Plane<std::int16_t>& disparity) { reference::match(ref, other, lo, hi, config, scratch, disparity); }

}  // namespace mctstereo::detail::cpu
