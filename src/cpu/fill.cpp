// Fills runs of invalid pixels along each row (cpu/fill_row-inl.h).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/fill.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/fill_row-inl.h"

#include <cstdint>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

void FillInvalid(Plane<std::int16_t>& disparity, FillMode mode) {
  const int w = disparity.width();
  parallel_lines(disparity.height(), [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) FillRow(disparity.row(y), w, mode);
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(FillInvalid);

void fill_invalid(Plane<std::int16_t>& disparity, FillMode mode) {
  if (mode == FillMode::None || disparity.empty()) return;
  HWY_DYNAMIC_DISPATCH(FillInvalid)(disparity, mode);
}
}  // namespace mctstereo::detail::cpu
#endif
