// pyramid_down on the device: kernels/pyramid.cl.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

PyramidDown::PyramidDown(Runtime& rt) : StageKernel(rt, "pyramid", "pyramid_down", "") {}

void PyramidDown::run(const DevicePlane<std::uint8_t>& src, DevicePlane<std::uint8_t>& dst) {
  if (dst.width != (src.width + 1) / 2 || dst.height != (src.height + 1) / 2)
    throw std::invalid_argument("pyramid_down: a " + std::to_string(src.width) + " x " + std::to_string(src.height) +
                                " plane reduces to " + std::to_string((src.width + 1) / 2) + " x " +
                                std::to_string((src.height + 1) / 2) + ", not " + std::to_string(dst.width) + " x " +
                                std::to_string(dst.height));
  if (dst.width == 0 || dst.height == 0) return;
  set_args(src.buffer, src.width, src.height, src.stride, dst.buffer, dst.width, dst.height, dst.stride);
  enqueue_chunks(dst.width, dst.height, "pyramid");
}

void pyramid_down(Runtime& rt, const DevicePlane<std::uint8_t>& src, DevicePlane<std::uint8_t>& dst) {
  PyramidDown(rt).run(src, dst);
}

}  // namespace mctstereo::detail::opencl
