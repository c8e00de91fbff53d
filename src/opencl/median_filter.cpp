// reference::median_filter on the device: kernels/median.cl, one program per window size.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

std::string median_options(int k) {
  if (k != 3 && k != 5) throw std::invalid_argument("median size " + std::to_string(k) + " is not 3 or 5");
  return "-DK=" + std::to_string(k);
}

}  // namespace

MedianFilter::MedianFilter(Runtime& rt, int k) : StageKernel(rt, "median", "median_filter", median_options(k)) {}

void MedianFilter::run(const DevicePlane<std::int16_t>& src, DevicePlane<std::int16_t>& dst) {
  if (dst.width != src.width || dst.height != src.height)
    throw std::invalid_argument("median_filter: destination " + std::to_string(dst.width) + "x" +
                                std::to_string(dst.height) + " differs from the source " + std::to_string(src.width) +
                                "x" + std::to_string(src.height));
  if (src.width == 0 || src.height == 0) return;
  set_args(src.buffer, src.stride, dst.buffer, dst.stride, src.width, src.height);
  enqueue_chunks(src.width, src.height, "median");
}

void median_filter(Runtime& rt, const DevicePlane<std::int16_t>& src, int k, DevicePlane<std::int16_t>& dst) {
  MedianFilter(rt, k).run(src, dst);
}

}  // namespace mctstereo::detail::opencl
