// reference::upscale on the device: kernels/upscale.cl, one program per factor.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

void upscale(Runtime& rt, const DevicePlane<std::int16_t>& src, int factor, int lo_q4, int hi_q4,
             DevicePlane<std::int16_t>& dst) {
  if (factor < 1) throw std::invalid_argument("upscale factor " + std::to_string(factor) + " is not positive");
  // Every destination pixel must have its source pixel (the reference reads it unchecked).
  if (static_cast<long>(dst.width) > static_cast<long>(src.width) * factor ||
      static_cast<long>(dst.height) > static_cast<long>(src.height) * factor)
    throw std::invalid_argument("upscale: destination " + std::to_string(dst.width) + "x" +
                                std::to_string(dst.height) + " exceeds " + std::to_string(factor) + " x the source " +
                                std::to_string(src.width) + "x" + std::to_string(src.height));
  if (dst.width == 0 || dst.height == 0) return;
  cl::Kernel kernel = rt.kernel("upscale", "upscale", "-DFACTOR=" + std::to_string(factor));
  kernel.setArg(0, src.buffer);
  kernel.setArg(1, src.stride);
  kernel.setArg(2, dst.buffer);
  kernel.setArg(3, dst.stride);
  kernel.setArg(4, dst.width);
  kernel.setArg(5, dst.height);
  kernel.setArg(6, lo_q4);
  kernel.setArg(7, hi_q4);
  // Work-groups of 16 chunks x 4 rows, rounded up, as in median_filter.cpp.
  rt.run(kernel, cl::NDRange((dst.width + 255) / 256 * 16, (dst.height + 3) / 4 * 4), cl::NDRange(16, 4), "upscale");
}

}  // namespace mctstereo::detail::opencl
