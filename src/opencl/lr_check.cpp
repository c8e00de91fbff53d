// reference::lr_check on the device: kernels/lr_check.cl, one program per direction.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

void lr_check(Runtime& rt, const DevicePlane<std::int16_t>& src, const DevicePlane<std::int16_t>& other, int dir,
              int threshold_q4, DevicePlane<std::int16_t>& dst) {
  if (dir != -1 && dir != 1) throw std::invalid_argument("lr_check: dir " + std::to_string(dir) + " is not -1 or +1");
  if (other.width != src.width || other.height != src.height || dst.width != src.width ||
      dst.height != src.height)
    throw std::invalid_argument("lr_check: the maps differ in size (" + std::to_string(src.width) + "x" +
                                std::to_string(src.height) + ", other " + std::to_string(other.width) + "x" +
                                std::to_string(other.height) + ", destination " + std::to_string(dst.width) + "x" +
                                std::to_string(dst.height) + ")");
  if (src.width == 0 || src.height == 0) return;
  cl::Kernel kernel = rt.kernel("lr_check", "lr_check", dir < 0 ? "-DDIR=-1" : "-DDIR=1");
  kernel.setArg(0, src.buffer);
  kernel.setArg(1, src.stride);
  kernel.setArg(2, other.buffer);
  kernel.setArg(3, other.stride);
  kernel.setArg(4, dst.buffer);
  kernel.setArg(5, dst.stride);
  kernel.setArg(6, src.width);
  kernel.setArg(7, src.height);
  kernel.setArg(8, threshold_q4);
  // Work-groups of 16 chunks x 4 rows, rounded up, as in median_filter.cpp.
  rt.run(kernel, cl::NDRange((src.width + 255) / 256 * 16, (src.height + 3) / 4 * 4), cl::NDRange(16, 4), "lr_check");
}

}  // namespace mctstereo::detail::opencl
