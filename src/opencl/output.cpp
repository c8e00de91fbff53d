// The caller's conventions on the device: kernels/output.cl, with or without the float map.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

void to_output(Runtime& rt, const DevicePlane<std::int16_t>& src, std::int16_t invalid_q4,
               DevicePlane<std::int16_t>& q4, DevicePlane<float>* disparity) {
  const auto same_size = [&](int w, int h) { return w == src.width && h == src.height; };
  if (!same_size(q4.width, q4.height) || (disparity != nullptr && !same_size(disparity->width, disparity->height)))
    throw std::invalid_argument("to_output: the output maps differ in size from the " + std::to_string(src.width) +
                                "x" + std::to_string(src.height) + " map");
  if (src.width == 0 || src.height == 0) return;
  const bool with_float = disparity != nullptr;
  cl::Kernel kernel = rt.kernel("output", "to_output", with_float ? "-DWITH_FLOAT=1" : "-DWITH_FLOAT=0");
  kernel.setArg(0, src.buffer);
  kernel.setArg(1, src.stride);
  kernel.setArg(2, static_cast<cl_int>(invalid_q4));
  kernel.setArg(3, q4.buffer);
  kernel.setArg(4, q4.stride);
  if (with_float) {
    kernel.setArg(5, disparity->buffer);
    kernel.setArg(6, disparity->stride);
  } else {
    kernel.setArg(5, sizeof(cl_mem), nullptr);  // a null buffer: the kernel does not touch it
    kernel.setArg(6, 0);
  }
  kernel.setArg(7, src.width);
  kernel.setArg(8, src.height);
  // Work-groups of 16 chunks x 4 rows, rounded up, as in median_filter.cpp.
  rt.run(kernel, cl::NDRange((src.width + 255) / 256 * 16, (src.height + 3) / 4 * 4), cl::NDRange(16, 4), "output");
}

}  // namespace mctstereo::detail::opencl
