// reference::grid_partner on the device: kernels/grid_partner.cl, one program per median size.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

std::string grid_partner_options(int median_size) {
  if (median_size != 0 && median_size != 3 && median_size != 5)
    throw std::invalid_argument("grid_partner: median size " + std::to_string(median_size) + " is not 0, 3 or 5");
  return "-DK=" + std::to_string(median_size);
}

}  // namespace

GridPartner::GridPartner(Runtime& rt, int median_size)
    : StageKernel(rt, "grid_partner", "grid_partner", grid_partner_options(median_size)) {}

void GridPartner::run(const DevicePlane<std::int16_t>& right, DevicePlane<std::int16_t>& partner) {
  if (partner.width != right.width || partner.height != right.height)
    throw std::invalid_argument("grid_partner: destination " + std::to_string(partner.width) + "x" +
                                std::to_string(partner.height) + " differs from the right map " +
                                std::to_string(right.width) + "x" + std::to_string(right.height));
  if (right.width == 0 || right.height == 0) return;
  set_args(right.buffer, right.stride, partner.buffer, partner.stride, right.width, right.height);
  enqueue_chunks(right.width, right.height, "lr_check");  // timed as part of the check it serves
}

void grid_partner(Runtime& rt, const DevicePlane<std::int16_t>& right, int median_size,
                  DevicePlane<std::int16_t>& partner) {
  GridPartner(rt, median_size).run(right, partner);
}

}  // namespace mctstereo::detail::opencl
