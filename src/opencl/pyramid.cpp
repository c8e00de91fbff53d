// pyramid_down on the device: kernels/pyramid.cl.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

// Work-groups of 16 x 4 work-items, each work-item 16 pixels of a row: a fixed size, so that
// drivers that compile per work-group size (PoCL) compile each program once; the kernels skip the
// work-items past the plane.
cl::NDRange global_for(int chunks, int rows) { return cl::NDRange((chunks + 15) / 16 * 16, (rows + 3) / 4 * 4); }
const cl::NDRange kLocal(16, 4);

}  // namespace

void pyramid_down(Runtime& rt, const DevicePlane<std::uint8_t>& src, DevicePlane<std::uint8_t>& dst) {
  if (dst.width != (src.width + 1) / 2 || dst.height != (src.height + 1) / 2)
    throw std::invalid_argument("pyramid_down: a " + std::to_string(src.width) + " x " + std::to_string(src.height) +
                                " plane reduces to " + std::to_string((src.width + 1) / 2) + " x " +
                                std::to_string((src.height + 1) / 2) + ", not " + std::to_string(dst.width) + " x " +
                                std::to_string(dst.height));
  if (dst.width == 0 || dst.height == 0) return;
  cl::Kernel kernel = rt.kernel("pyramid", "pyramid_down");
  kernel.setArg(0, src.buffer);
  kernel.setArg(1, src.width);
  kernel.setArg(2, src.height);
  kernel.setArg(3, src.stride);
  kernel.setArg(4, dst.buffer);
  kernel.setArg(5, dst.width);
  kernel.setArg(6, dst.height);
  kernel.setArg(7, dst.stride);
  rt.run(kernel, global_for((dst.width + 15) / 16, dst.height), kLocal, "pyramid");
}

}  // namespace mctstereo::detail::opencl
