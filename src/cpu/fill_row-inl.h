// Fills runs of invalid pixels along a row from the run's two valid neighbours, per SIMD target
// (fill.cpp and the finest level's refinement in strips, refine_left_map.cpp, share it).
//
// Disparity maps hold many short invalid runs (often single pixels), so a pixel-by-pixel scan is
// dominated by mispredicted branches. Instead, SIMD compares turn 32 pixels at a time into a bit
// mask of invalid pixels; the starts and ends of runs are bit transitions of that mask, visited
// with bit scans, and runs of up to one short vector are written with one blended store.
// Included after <hwy/highway.h> by files that use foreach_target.h; the toggled guard is
// Highway's idiom for that.
#if defined(MCTSTEREO_CPU_FILL_ROW_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_FILL_ROW_INL_H_
#undef MCTSTEREO_CPU_FILL_ROW_INL_H_
#else
#define MCTSTEREO_CPU_FILL_ROW_INL_H_
#endif

#include <hwy/highway.h>

#include "cpu/mask_bits-inl.h"

#include <algorithm>
#include <bit>
#include <cstdint>

#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using FillShortTag = hn::CappedTag<std::int16_t, 8>;  // writes the short runs

// Fills the invalid run [s, e) of a row w wide.
HWY_INLINE void FillRun(std::int16_t* row, int s, int e, int w, FillMode mode) {
  if (s == 0 && e == w) return;  // no valid pixel in the row
  if (s == 0 || e == w) {
    std::fill(row + s, row + e, s == 0 ? row[e] : row[s - 1]);
    return;
  }
  const std::int16_t left = row[s - 1], right = row[e];
  const std::int16_t lower = std::min(left, right);
  // Pixel s + t is 1 + t from the left neighbour and len - t from the right one: the first
  // len / 2 are closer to the left, the last len / 2 to the right, and an odd run has one pixel
  // in the middle at equal distance, which takes the smaller value.
  const int len = e - s, half = mode == FillMode::NearestLower ? 0 : len / 2;
  const FillShortTag ds;
  if (len <= static_cast<int>(hn::Lanes(ds))) {
    // Lanes past the run rewrite the values they hold (the row's slack at the end of a row).
    const auto t = hn::Iota(ds, 0);
    const auto v = hn::IfThenElse(hn::Lt(t, hn::Set(ds, half)), hn::Set(ds, left),
                                  hn::IfThenElse(hn::Lt(t, hn::Set(ds, len - half)), hn::Set(ds, lower),
                                                 hn::Set(ds, right)));
    hn::StoreU(hn::IfThenElse(hn::FirstN(ds, len), v, hn::LoadU(ds, row + s)), ds, row + s);
    return;
  }
  std::fill(row + s, row + s + half, left);
  std::fill(row + s + half, row + e - half, lower);
  std::fill(row + e - half, row + e, right);
}

// Fills the invalid runs of one row w wide (with the planes' 64 bytes of slack after w).
HWY_INLINE void FillRow(std::int16_t* row, int w, FillMode mode) {
  const MaskTag16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto invalid = hn::Set(d, kInvalid);
  int start = 0;            // first pixel of the open run
  std::uint32_t carry = 0;  // whether the pixel before the current word is invalid
  for (int x0 = 0; x0 < w; x0 += 32) {
    std::uint32_t bad = 0;
    for (int x = x0; x < std::min(x0 + 32, w); x += n) bad |= MaskBits(hn::Eq(hn::LoadU(d, row + x), invalid)) << (x - x0);
    // Bits at and past w (the slack) count as valid pixels that end no run.
    const std::uint32_t in_row = w - x0 >= 32 ? ~0u : (1u << (w - x0)) - 1;
    bad &= in_row;
    const std::uint32_t bad_before = (bad << 1) | carry;  // bit i: pixel x0 + i - 1 is invalid
    carry = bad >> 31;
    const std::uint32_t starts = bad & ~bad_before;
    const std::uint32_t ends = ~bad & bad_before & in_row;
    // Starts and ends alternate, so each end closes the run of the start before it.
    for (std::uint32_t events = starts | ends; events != 0; events &= events - 1) {
      const int b = std::countr_zero(events);
      if ((starts >> b) & 1u) start = x0 + b;
      else FillRun(row, start, x0 + b, w, mode);
    }
  }
  if (row[w - 1] == kInvalid) FillRun(row, start, w, w, mode);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
