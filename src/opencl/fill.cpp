// reference::fill_invalid on the device, in place: kernels/fill.cl, a work-item per row.
#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

FillInvalid::FillInvalid(Runtime& rt, FillMode mode) : StageKernel(rt), mode_(mode) {
  if (mode != FillMode::None)
    kernel_ =
        rt.kernel("fill", "fill_invalid", mode == FillMode::NearestLower ? "-DNEAREST_LOWER=1" : "-DNEAREST_LOWER=0");
}

void FillInvalid::run(DevicePlane<std::int16_t>& disparity) {
  if (mode_ == FillMode::None || disparity.width == 0 || disparity.height == 0) return;
  set_args(disparity.buffer, disparity.stride, disparity.width, disparity.height);
  // Work-groups of 64 rows, rounded up (the kernel skips the excess): one fixed shape, for the
  // reasons in StageKernel::enqueue_chunks.
  enqueue(cl::NDRange((disparity.height + 63) / 64 * 64), cl::NDRange(64), "fill");
}

void fill_invalid(Runtime& rt, DevicePlane<std::int16_t>& disparity, FillMode mode) {
  FillInvalid(rt, mode).run(disparity);
}

}  // namespace mctstereo::detail::opencl
