// search_ranges with Highway SIMD: per-pixel [lo, hi] from the 3x3 neighbourhood of the coarse
// prior. The range depends only on the coarse pixel (x/2, y/2), so it is computed once per coarse
// pixel and then replicated 2 x 2.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/search_ranges.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstring>
#include <limits>

#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Coarse columns per pass over a row; their column minima and maxima live in stack arrays.
constexpr int kChunk = 256;
// i16 lanes of the widest vector used: 64 bytes, the slack every Plane row has past its end.
constexpr int kMaxLanes = 32;

using D16 = hn::CappedTag<std::int16_t, kMaxLanes>;

// Ranges of coarse columns [0, ncx) of coarse row cy, replicated into output row `lo_row` /
// `hi_row` of `out_width` pixels (output x reads coarse column min(x / 2, cw - 1)).
//
// Arithmetic stays in int16: v >> 4 lies in [-2048, 2047], so 2 v cannot overflow, and the
// saturating +- radius (a small number) only saturates where the reference's int result lies
// outside int16 too, which the clip to [dmin, dmax] (int16 values) then maps to the same bound.
void RangeRow(const Plane<std::int16_t>& coarse, int cy, int ncx, int dmin, int dmax, int radius,
              int out_width, std::int16_t* HWY_RESTRICT lo_row, std::int16_t* HWY_RESTRICT hi_row) {
  const D16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int cw = coarse.width(), ch = coarse.height();
  const std::int16_t* above = coarse.row(clamp_index(cy - 1, ch));
  const std::int16_t* centre = coarse.row(cy);
  const std::int16_t* below = coarse.row(clamp_index(cy + 1, ch));
  const auto invalid = hn::Set(d, kInvalid);
  const auto largest = hn::Set(d, std::numeric_limits<std::int16_t>::max());
  const auto vmin = hn::Set(d, static_cast<std::int16_t>(dmin));
  const auto vmax = hn::Set(d, static_cast<std::int16_t>(dmax));
  const auto vr = hn::Set(d, static_cast<std::int16_t>(std::clamp(radius, -32768, 32767)));
  // Index 0 holds coarse column c0 - 1; vectors may run up to a vector past the last entry needed.
  HWY_ALIGN std::int16_t col_min[kChunk + 2 + kMaxLanes];
  HWY_ALIGN std::int16_t col_max[kChunk + 2 + kMaxLanes];
  HWY_ALIGN std::int16_t lo_buf[kChunk + kMaxLanes];
  HWY_ALIGN std::int16_t hi_buf[kChunk + kMaxLanes];

  for (int c0 = 0; c0 < ncx; c0 += kChunk) {
    const int c1 = std::min(c0 + kChunk, ncx);
    // Column minima and maxima over the three rows. kInvalid (INT16_MIN) never wins a maximum over
    // a valid value; for the minimum it is replaced by INT16_MAX. A column without valid values
    // leaves INT16_MAX / INT16_MIN, which lose against any valid neighbour; if the centre is
    // valid there is one, and if it is not the result is discarded.
    for (int k = std::max(c0 - 1, 0); k < std::min(c1 + 1, cw); k += n) {
      const auto a = hn::LoadU(d, above + k), b = hn::LoadU(d, centre + k), c = hn::LoadU(d, below + k);
      auto for_min = [&](hn::Vec<D16> v) { return hn::IfThenElse(hn::Eq(v, invalid), largest, v); };
      hn::StoreU(hn::Min(hn::Min(for_min(a), for_min(b)), for_min(c)), d, col_min + (k - c0 + 1));
      hn::StoreU(hn::Max(hn::Max(a, b), c), d, col_max + (k - c0 + 1));
    }
    if (c0 == 0) col_min[0] = col_min[1], col_max[0] = col_max[1];  // column -1 repeats column 0
    if (c1 == cw) col_min[cw - c0 + 1] = col_min[cw - c0], col_max[cw - c0 + 1] = col_max[cw - c0];

    for (int k = c0; k < c1; k += n) {
      const int i = k - c0 + 1;
      const auto mn = hn::Min(hn::Min(hn::LoadU(d, col_min + i - 1), hn::LoadU(d, col_min + i)),
                              hn::LoadU(d, col_min + i + 1));
      const auto mx = hn::Max(hn::Max(hn::LoadU(d, col_max + i - 1), hn::LoadU(d, col_max + i)),
                              hn::LoadU(d, col_max + i + 1));
      const auto mn_px = hn::ShiftRight<4>(mn), mx_px = hn::ShiftRight<4>(mx);  // floor, as v >> 4
      const auto lo = hn::Min(hn::Max(vmin, hn::SaturatedSub(hn::Add(mn_px, mn_px), vr)), vmax);
      const auto hi = hn::Max(hn::Min(vmax, hn::SaturatedAdd(hn::Add(mx_px, mx_px), vr)), vmin);
      const auto prior_invalid = hn::Eq(hn::LoadU(d, centre + k), invalid);
      hn::StoreU(hn::IfThenElse(prior_invalid, vmin, lo), d, lo_buf + (k - c0));
      hn::StoreU(hn::IfThenElse(prior_invalid, vmax, hi), d, hi_buf + (k - c0));
    }

    // Each coarse range covers output columns 2k and 2k + 1.
    const int x_end = std::min(2 * c1, out_width);
    int k = c0;
    for (; 2 * (k + n) <= x_end; k += n) {
      const auto l = hn::LoadU(d, lo_buf + (k - c0)), u = hn::LoadU(d, hi_buf + (k - c0));
      hn::StoreInterleaved2(l, l, d, lo_row + 2 * k);
      hn::StoreInterleaved2(u, u, d, hi_row + 2 * k);
    }
    for (int x = 2 * k; x < x_end; ++x) {
      lo_row[x] = lo_buf[x / 2 - c0];
      hi_row[x] = hi_buf[x / 2 - c0];
    }
  }
  // Output columns past 2 cw (an odd width over a coarse level of floor(W / 2)) read column cw - 1.
  for (int x = 2 * ncx; x < out_width; ++x) {
    lo_row[x] = lo_row[2 * ncx - 1];
    hi_row[x] = hi_row[2 * ncx - 1];
  }
}

void SearchRanges(const Plane<std::int16_t>* coarse, int dmin, int dmax, int radius, Plane<std::int16_t>& lo,
                  Plane<std::int16_t>& hi) {
  const int w = lo.width(), h = lo.height();
  if (w == 0 || h == 0) return;
  if (coarse == nullptr) {
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; ++y) {
      std::fill_n(lo.row(y), w, static_cast<std::int16_t>(dmin));
      std::fill_n(hi.row(y), w, static_cast<std::int16_t>(dmax));
    }
    return;
  }
  const int cw = coarse->width(), ch = coarse->height();
  // Coarse rows and columns that some output pixel reads.
  const int ncx = std::min(cw, (w + 1) / 2), ncy = std::min(ch, (h + 1) / 2);
#pragma omp parallel for schedule(static)
  for (int cy = 0; cy < ncy; ++cy) {
    const int y0 = 2 * cy;
    // The last coarse row also serves output rows past 2 ch.
    const int y_end = cy == ch - 1 ? h : std::min(y0 + 2, h);
    RangeRow(*coarse, cy, ncx, dmin, dmax, radius, w, lo.row(y0), hi.row(y0));
    for (int y = y0 + 1; y < y_end; ++y) {
      std::memcpy(lo.row(y), lo.row(y0), sizeof(std::int16_t) * w);
      std::memcpy(hi.row(y), hi.row(y0), sizeof(std::int16_t) * w);
    }
  }
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
