// k x k median of a disparity map, row by row (cpu/median_row-inl.h).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/median_filter.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/median_row-inl.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

void MedianFilter(const Plane<std::int16_t>& src, int k, Plane<std::int16_t>& dst) {
  parallel_lines(src.height(), [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) MedianOfMapRow(src, k, y, dst.row(y));
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(MedianFilter);

void median_filter(const Plane<std::int16_t>& src, int k, Plane<std::int16_t>& dst) {
  if (k != 3 && k != 5) {
    reference::median_filter(src, k, dst);  // other sizes are not offered by the parameters
    return;
  }
  HWY_DYNAMIC_DISPATCH(MedianFilter)(src, k, dst);
}
}  // namespace mctstereo::detail::cpu
#endif
