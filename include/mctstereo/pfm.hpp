// mctstereo: one-channel PFM files (Portable Float Map), as the program writes disparity and depth
// maps and as Middlebury 2014 stores ground truth.
//
// The layout: "Pf\n", "WIDTH HEIGHT\n", a scale whose sign is the byte order ("-1.0\n": little-
// endian), one whitespace byte, then WIDTH x HEIGHT 32-bit floats, the bottom row first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "mctstereo/image.hpp"

namespace mctstereo {

/// What a PFM file written by the library holds where there is no value (no disparity, no depth).
inline constexpr float kPfmNone = std::numeric_limits<float>::infinity();

/// A float map that owns its values, row-major, top row first.
struct FloatMap {
  int width = 0;
  int height = 0;
  std::vector<float> values;  ///< width x height, row by row

  MapView<const float> view() const { return {values.data(), width, height, width}; }
  MapView<float> view() { return {values.data(), width, height, width}; }
};

/// The bytes of a one-channel PFM file of `map`: header "Pf", "W H", "-1.0" (little-endian), rows
/// bottom to top; every value that is not finite (NaN, +/-inf) is written as kPfmNone.
std::vector<std::uint8_t> encode_pfm(MapView<const float> map);

/// The map of a one-channel PFM file's bytes, top row first, values as stored (either byte order).
/// std::runtime_error naming `name` ("'gt.pfm'", say) and what is wrong: not a PFM, a colour PFM
/// ("PF"), a malformed header, a size beyond 65536 x 65536, or fewer samples than the size needs.
FloatMap decode_pfm(std::string_view bytes, const std::string& name = "the PFM data");

/// encode_pfm written to `out`; std::runtime_error when the stream fails.
void write_pfm(std::ostream& out, MapView<const float> map);
/// decode_pfm of what remains in `in`.
FloatMap read_pfm(std::istream& in, const std::string& name = "the PFM data");

}  // namespace mctstereo
