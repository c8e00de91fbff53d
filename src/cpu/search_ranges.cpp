// search_ranges with Highway SIMD: per-pixel [lo, hi] from the 3x3 neighbourhood of the coarse
// prior, one row per coarse row (search_range-inl.h), copied to the second fine row.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/search_ranges.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstring>

#include "cpu/parallel.hpp"
#include "stages.hpp"

#include "cpu/search_range-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

void SearchRanges(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius, Plane<std::int16_t>& lo,
                  Plane<std::int16_t>& hi) {
  const int w = lo.width(), h = lo.height();
  if (w == 0 || h == 0) return;
  if (coarse == nullptr) {
    parallel_lines(h, [&](int y0, int y1) {
      for (int y = y0; y < y1; ++y) {
        std::fill_n(lo.row(y), w, static_cast<std::int16_t>(dmin));
        std::fill_n(hi.row(y), w, static_cast<std::int16_t>(dmax));
      }
    });
    return;
  }
  const int ch = coarse->height();
  const int ncy = std::min(ch, (h + 1) / 2);  // coarse rows that some output row reads
  parallel_lines(ncy, [&](int cy0, int cy1) {
    for (int cy = cy0; cy < cy1; ++cy) {
      const int y0 = 2 * cy;
      // The last coarse row also serves output rows past 2 ch.
      const int y_end = cy == ch - 1 ? h : std::min(y0 + 2, h);
      // Segments through buffers with the slack PriorRangeSegment writes into.
      constexpr int kSegment = 512;
      HWY_ALIGN std::int16_t seg_lo[kSegment + kRangeSegmentSlack], seg_hi[kSegment + kRangeSegmentSlack];
      for (int x = 0; x < w; x += kSegment) {
        const int n = std::min(kSegment, w - x);
        PriorRangeSegment(*coarse, cy, x, x + n, dmin, dmax, radius, seg_lo, seg_hi);
        std::memcpy(lo.row(y0) + x, seg_lo, sizeof(std::int16_t) * n);
        std::memcpy(hi.row(y0) + x, seg_hi, sizeof(std::int16_t) * n);
      }
      for (int y = y0 + 1; y < y_end; ++y) {
        std::memcpy(lo.row(y), lo.row(y0), sizeof(std::int16_t) * w);
        std::memcpy(hi.row(y), hi.row(y0), sizeof(std::int16_t) * w);
      }
    }
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(SearchRanges);
void search_ranges(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius, Plane<std::int16_t>& lo,
                   Plane<std::int16_t>& hi) {
  HWY_DYNAMIC_DISPATCH(SearchRanges)(coarse, dmin, dmax, radius, lo, hi);
}
}  // namespace mctstereo::detail::cpu
#endif
