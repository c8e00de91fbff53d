// Left-right consistency check of a map, row by row (cpu/lr_check_row-inl.h).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/lr_check.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/lr_check_row-inl.h"

#include <cstdint>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

void LrCheck(const Plane<std::int16_t>& src, const Plane<std::int16_t>& other, int dir, int threshold_q4,
             Plane<std::int16_t>& dst) {
  const int w = src.width();
  parallel_lines(src.height(), [&](int y0, int y1) {
    HWY_ALIGN std::int16_t ext[kLrExtEntries];
    LrExtInit(ext);
    for (int y = y0; y < y1; ++y) LrCheckRow(src.row(y), other.row(y), w, dir, threshold_q4, dst.row(y), ext);
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(LrCheck);

void lr_check(const Plane<std::int16_t>& src, const Plane<std::int16_t>& other, int dir, int threshold_q4,
              Plane<std::int16_t>& dst) {
  HWY_DYNAMIC_DISPATCH(LrCheck)(src, other, dir, threshold_q4, dst);
}
}  // namespace mctstereo::detail::cpu
#endif
