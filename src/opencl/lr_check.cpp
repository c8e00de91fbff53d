// reference::lr_check on the device: kernels/lr_check.cl, one program per direction.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

const char* lr_check_options(int dir) {
  if (dir != -1 && dir != 1) throw std::invalid_argument("lr_check: dir " + std::to_string(dir) + " is not -1 or +1");
  return dir < 0 ? "-DDIR=-1" : "-DDIR=1";
}

}  // namespace

LrCheck::LrCheck(Runtime& rt, int dir) : StageKernel(rt, "lr_check", "lr_check", lr_check_options(dir)) {}

void LrCheck::run(const DevicePlane<std::int16_t>& src, const DevicePlane<std::int16_t>& other, int threshold_q4,
                  DevicePlane<std::int16_t>& dst) {
  if (other.width != src.width || other.height != src.height || dst.width != src.width ||
      dst.height != src.height)
    throw std::invalid_argument("lr_check: the maps differ in size (" + std::to_string(src.width) + "x" +
                                std::to_string(src.height) + ", other " + std::to_string(other.width) + "x" +
                                std::to_string(other.height) + ", destination " + std::to_string(dst.width) + "x" +
                                std::to_string(dst.height) + ")");
  if (src.width == 0 || src.height == 0) return;
  set_args(src.buffer, src.stride, other.buffer, other.stride, dst.buffer, dst.stride, src.width, src.height,
           threshold_q4);
  enqueue_chunks(src.width, src.height, "lr_check");
}

void lr_check(Runtime& rt, const DevicePlane<std::int16_t>& src, const DevicePlane<std::int16_t>& other, int dir,
              int threshold_q4, DevicePlane<std::int16_t>& dst) {
  LrCheck(rt, dir).run(src, other, threshold_q4, dst);
}

}  // namespace mctstereo::detail::opencl
