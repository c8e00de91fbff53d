// PFM reader (mctstereo::decode_pfm, behind eval's ground truth and every .pfm the program reads):
// any bytes either decode to a map whose size matches its values, or throw std::runtime_error.
// A decoded map is encoded again and must decode to the same values (NaN stays NaN-free: the
// writer stores every non-finite value as +inf).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "mctstereo/pfm.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mctstereo;
  FloatMap map;
  try {
    map = decode_pfm(std::string_view(reinterpret_cast<const char*>(data), size), "'fuzz.pfm'");
  } catch (const std::runtime_error&) {
    return 0;
  }
  if (map.width <= 0 || map.height <= 0 ||
      map.values.size() != static_cast<std::size_t>(map.width) * static_cast<std::size_t>(map.height))
    std::abort();
  const std::vector<std::uint8_t> bytes = encode_pfm(std::as_const(map).view());
  const FloatMap again = decode_pfm(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  if (again.width != map.width || again.height != map.height) std::abort();
  for (std::size_t i = 0; i < map.values.size(); ++i) {
    const float a = map.values[i], b = again.values[i];
    if (std::isfinite(a) ? std::memcmp(&a, &b, sizeof a) != 0 : b != kPfmNone) std::abort();
  }
  return 0;
}
