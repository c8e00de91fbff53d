// PLACEHOLDER: forwards to the reference until the SIMD version lands.
#include "stages.hpp"

namespace mctstereo::detail::cpu {

void census_transform(const Plane<std::uint8_t>& image, const CensusConfig& config, CensusCodes& codes) { reference::census_transform(image, config, codes); }

}  // namespace mctstereo::detail::cpu
