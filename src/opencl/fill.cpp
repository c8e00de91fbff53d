// reference::fill_invalid on the device, in place: kernels/fill.cl, a work-item per row.
#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

void fill_invalid(Runtime& rt, DevicePlane<std::int16_t>& disparity, FillMode mode) {
  if (mode == FillMode::None || disparity.width == 0 || disparity.height == 0) return;
  cl::Kernel kernel =
      rt.kernel("fill", "fill_invalid", mode == FillMode::NearestLower ? "-DNEAREST_LOWER=1" : "-DNEAREST_LOWER=0");
  kernel.setArg(0, disparity.buffer);
  kernel.setArg(1, disparity.stride);
  kernel.setArg(2, disparity.width);
  kernel.setArg(3, disparity.height);
  // Work-groups of 64 rows, rounded up (the kernel skips the excess): one fixed shape, for the
  // reasons in median_filter.cpp.
  rt.run(kernel, cl::NDRange((disparity.height + 63) / 64 * 64), cl::NDRange(64), "fill");
}

}  // namespace mctstereo::detail::opencl
