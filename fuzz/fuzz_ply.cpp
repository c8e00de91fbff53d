// PLY reader (mctstereo::read_ply, as `render` reads a cloud): any bytes either give a cloud whose
// arrays agree in size, or throw std::runtime_error. A cloud read is written as binary PLY and
// must read back to the same points and colours.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>

#include "mctstereo/depth.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mctstereo;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  PointCloud cloud;
  try {
    cloud = read_ply(in, "point cloud 'fuzz.ply'");
  } catch (const std::runtime_error&) {
    return 0;
  }
  if (cloud.xyz.size() % 3 != 0 || (cloud.has_colours() && cloud.rgb.size() != cloud.xyz.size()) ||
      !cloud.pixel.empty())
    std::abort();
  std::ostringstream out;
  write_ply(out, cloud);
  std::istringstream back(out.str());
  const PointCloud again = read_ply(back);
  if (again.xyz.size() != cloud.xyz.size() || again.rgb != cloud.rgb) std::abort();
  // Bit for bit, NaN included (the writer copies the floats as they are).
  if (!cloud.xyz.empty() && std::memcmp(again.xyz.data(), cloud.xyz.data(), cloud.xyz.size() * sizeof(float)) != 0)
    std::abort();
  return 0;
}
