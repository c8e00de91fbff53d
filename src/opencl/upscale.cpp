// reference::upscale on the device: kernels/upscale.cl, one program per factor.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

std::string upscale_options(int factor) {
  if (factor < 1) throw std::invalid_argument("upscale factor " + std::to_string(factor) + " is not positive");
  return "-DFACTOR=" + std::to_string(factor);
}

}  // namespace

Upscale::Upscale(Runtime& rt, int factor)
    : StageKernel(rt, "upscale", "upscale", upscale_options(factor)), factor_(factor) {}

void Upscale::run(const DevicePlane<std::int16_t>& src, int lo_q4, int hi_q4, DevicePlane<std::int16_t>& dst) {
  // Every destination pixel must have its source pixel (the reference reads it unchecked).
  if (static_cast<long>(dst.width) > static_cast<long>(src.width) * factor_ ||
      static_cast<long>(dst.height) > static_cast<long>(src.height) * factor_)
    throw std::invalid_argument("upscale: destination " + std::to_string(dst.width) + "x" +
                                std::to_string(dst.height) + " exceeds " + std::to_string(factor_) + " x the source " +
                                std::to_string(src.width) + "x" + std::to_string(src.height));
  if (dst.width == 0 || dst.height == 0) return;
  set_args(src.buffer, src.stride, dst.buffer, dst.stride, dst.width, dst.height, lo_q4, hi_q4);
  enqueue_chunks(dst.width, dst.height, "upscale");
}

void upscale(Runtime& rt, const DevicePlane<std::int16_t>& src, int factor, int lo_q4, int hi_q4,
             DevicePlane<std::int16_t>& dst) {
  Upscale(rt, factor).run(src, lo_q4, hi_q4, dst);
}

}  // namespace mctstereo::detail::opencl
