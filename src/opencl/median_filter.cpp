// reference::median_filter on the device: kernels/median.cl, one program per window size.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

void median_filter(Runtime& rt, const DevicePlane<std::int16_t>& src, int k, DevicePlane<std::int16_t>& dst) {
  if (k != 3 && k != 5) throw std::invalid_argument("median size " + std::to_string(k) + " is not 3 or 5");
  if (dst.width != src.width || dst.height != src.height)
    throw std::invalid_argument("median_filter: destination " + std::to_string(dst.width) + "x" +
                                std::to_string(dst.height) + " differs from the source " + std::to_string(src.width) +
                                "x" + std::to_string(src.height));
  if (src.width == 0 || src.height == 0) return;
  cl::Kernel kernel = rt.kernel("median", "median_filter", "-DK=" + std::to_string(k));
  kernel.setArg(0, src.buffer);
  kernel.setArg(1, src.stride);
  kernel.setArg(2, dst.buffer);
  kernel.setArg(3, dst.stride);
  kernel.setArg(4, src.width);
  kernel.setArg(5, src.height);
  // Work-groups of 16 chunks of 16 pixels x 4 rows, the range rounded up to whole groups (the
  // kernel skips the excess): 64 work-items fill whole SIMD groups of 32 or 64 on GPUs, and one
  // fixed shape means one compiled work-group function on CPU drivers that compile one per local
  // size (PoCL), where a driver-chosen size would differ with the map size.
  rt.run(kernel, cl::NDRange((src.width + 255) / 256 * 16, (src.height + 3) / 4 * 4), cl::NDRange(16, 4), "median");
}

}  // namespace mctstereo::detail::opencl
