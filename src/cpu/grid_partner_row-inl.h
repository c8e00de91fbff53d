// One row of the left map's LR partners on the right map's grid of even rows and columns
// (StereoParams::lr_check_grid), per SIMD target: the grid_partner stage (grid_partner.cpp) and
// the finest level's refinement in strips (refine_left_map.cpp) share it. A grid row is the right
// map's even columns of an even row, split off by the deinterleaving load; its median runs on the
// grid with the median filter's own row function, and the result goes out twice per entry
// through the interleaving store. Included after <hwy/highway.h> by files that use
// foreach_target.h; the toggled guard is Highway's idiom for that.
#if defined(MCTSTEREO_CPU_GRID_PARTNER_ROW_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_GRID_PARTNER_ROW_INL_H_
#undef MCTSTEREO_CPU_GRID_PARTNER_ROW_INL_H_
#else
#define MCTSTEREO_CPU_GRID_PARTNER_ROW_INL_H_
#endif

#include <hwy/highway.h>

#include <cstddef>
#include <cstdint>

#include "cpu/median_row-inl.h"
#include "stages.hpp"

#ifndef MCTSTEREO_CPU_GRID_PARTNER_LAYOUT
#define MCTSTEREO_CPU_GRID_PARTNER_LAYOUT
namespace mctstereo::detail::cpu {
/// Rows of a thread's grid scratch: up to 5 grid rows of a median's window and the median row.
inline constexpr int kGridScratchRows = 6;
/// Entries of one grid row in the scratch: ceil(width / 2) and the 64 bytes of slack that the
/// median's row function reads past a row, in whole 64-byte lines.
inline std::ptrdiff_t grid_row_stride(int width) { return Plane<std::int16_t>::stride_for((width + 1) / 2, 0); }
/// Bytes of the grid rows of one thread, from a 64-byte boundary.
inline std::size_t grid_rows_bytes(int width) {
  return static_cast<std::size_t>(kGridScratchRows * grid_row_stride(width)) * sizeof(std::int16_t);
}
}  // namespace mctstereo::detail::cpu
#endif  // MCTSTEREO_CPU_GRID_PARTNER_LAYOUT

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// dst[i] = src[2 i] for i < ceil(w / 2). Whole vectors only where their pairs end inside the row.
HWY_INLINE void EvenColumns(const std::int16_t* src, int w, std::int16_t* dst) {
  const hn::ScalableTag<std::int16_t> d;
  const int n = static_cast<int>(hn::Lanes(d));
  int i = 0;
  for (; 2 * (i + n) <= w; i += n) {
    hn::Vec<decltype(d)> even, odd;
    hn::LoadInterleaved2(d, src + 2 * i, even, odd);
    hn::StoreU(even, d, dst + i);
  }
  for (; 2 * i < w; ++i) dst[i] = src[2 * i];
}

// out[x] = src[x / 2] for x < w.
HWY_INLINE void EachTwice(const std::int16_t* src, int w, std::int16_t* out) {
  const hn::ScalableTag<std::int16_t> d;
  const int n = static_cast<int>(hn::Lanes(d));
  int i = 0;
  for (; 2 * (i + n) <= w; i += n) {
    const auto v = hn::LoadU(d, src + i);
    hn::StoreInterleaved2(v, v, d, out + 2 * i);
  }
  for (int x = 2 * i; x < w; ++x) out[x] = src[x / 2];
}

// Rows 2j and 2j + 1 of the partner map (they are equal) into out, w entries: grid rows
// j - k/2 .. j + k/2 (clamped to the grid) into the scratch rows, their k x k median on the grid
// (k = 3, 5; 0: grid row j itself), each entry twice. rows: kGridScratchRows rows of `stride`
// entries (grid_row_stride()).
HWY_INLINE void GridPartnerRow(const Plane<std::int16_t>& right, int k, int j, std::int16_t* rows,
                               std::ptrdiff_t stride, std::int16_t* out) {
  const int w = right.width(), gw = (w + 1) / 2, gh = (right.height() + 1) / 2;
  const int taps = k > 0 ? k : 1;
  const std::int16_t* window[5];
  for (int t = 0; t < taps; ++t) {
    std::int16_t* row = rows + t * stride;
    EvenColumns(right.row(2 * clamp_index(j + t - taps / 2, gh)), w, row);
    window[t] = row;
  }
  const std::int16_t* grid_row = window[0];
  if (k > 0) {
    std::int16_t* median = rows + (kGridScratchRows - 1) * stride;
    if (k == 3) MedianRow<3>(window, gw, median);
    else MedianRow<5>(window, gw, median);
    grid_row = median;
  }
  EachTwice(grid_row, w, out);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
