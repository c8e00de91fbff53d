// Per-target helper shared by search_ranges and match: the search ranges of a segment of one row
// from the coarse prior (search_range_at() of stages.hpp, vectorised). The range depends only on
// the coarse pixel (x/2, y/2), so it is computed once per coarse pixel and then replicated 2 x.
// Included after <hwy/highway.h> by files that use foreach_target.h; the toggled guard is
// Highway's idiom for a header compiled once per SIMD target.
#if defined(MCTSTEREO_CPU_SEARCH_RANGE_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_SEARCH_RANGE_INL_H_
#undef MCTSTEREO_CPU_SEARCH_RANGE_INL_H_
#else
#define MCTSTEREO_CPU_SEARCH_RANGE_INL_H_
#endif

#include <hwy/highway.h>

#include <algorithm>
#include <cstdint>
#include <limits>

#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

/// Values past the end that PriorRangeSegment may write: its outputs must have this much room.
inline constexpr int kRangeSegmentSlack = 64;

// Column minima and maxima of a Q4 map over three rows, for the columns [k_begin, k_end), into
// col_min[k - origin] and col_max[k - origin] (whole vectors: up to a vector past k_end). kInvalid
// (INT16_MIN) never wins a maximum over a valid value; for the minimum it is replaced by INT16_MAX.
// A column without valid values leaves INT16_MAX / INT16_MIN, which lose against any valid
// neighbour; the callers discard the result where the centre pixel is invalid. Loads past the
// row's end stay inside its 64-byte slack; their lanes are not used.
template <class D>
inline void ThreeRowExtrema(D d, const std::int16_t* above, const std::int16_t* centre, const std::int16_t* below,
                            int k_begin, int k_end, int origin, std::int16_t* HWY_RESTRICT col_min,
                            std::int16_t* HWY_RESTRICT col_max) {
  namespace hn = hwy::HWY_NAMESPACE;
  const auto invalid = hn::Set(d, kInvalid);
  const auto largest = hn::Set(d, std::numeric_limits<std::int16_t>::max());
  const auto for_min = [&](hn::Vec<D> v) { return hn::IfThenElse(hn::Eq(v, invalid), largest, v); };
  for (int k = k_begin; k < k_end; k += static_cast<int>(hn::Lanes(d))) {
    const auto a = hn::LoadU(d, above + k), b = hn::LoadU(d, centre + k), c = hn::LoadU(d, below + k);
    hn::StoreU(hn::Min(hn::Min(for_min(a), for_min(b)), for_min(c)), d, col_min + (k - origin));
    hn::StoreU(hn::Max(hn::Max(a, b), c), d, col_max + (k - origin));
  }
}

// The minimum of ThreeRowExtrema's minima i - 1, i and i + 1, and the maximum of its maxima: the
// 3x3 extrema. (Two functions returning vectors: SVE vectors cannot sit in a struct.)
template <class D>
inline hwy::HWY_NAMESPACE::Vec<D> ThreeColumnMin(D d, const std::int16_t* col_min, int i) {
  namespace hn = hwy::HWY_NAMESPACE;
  return hn::Min(hn::Min(hn::LoadU(d, col_min + i - 1), hn::LoadU(d, col_min + i)), hn::LoadU(d, col_min + i + 1));
}
template <class D>
inline hwy::HWY_NAMESPACE::Vec<D> ThreeColumnMax(D d, const std::int16_t* col_max, int i) {
  namespace hn = hwy::HWY_NAMESPACE;
  return hn::Max(hn::Max(hn::LoadU(d, col_max + i - 1), hn::LoadU(d, col_max + i)), hn::LoadU(d, col_max + i + 1));
}

// Ranges of the fine columns [x_begin, x_end) of a row that reads coarse row cy (x_begin even),
// into lo_out[x - x_begin] and hi_out[x - x_begin]. Fine column x reads coarse column
// min(x / 2, cw - 1). Whole vectors are written, up to kRangeSegmentSlack values past x_end:
// at the widths of a matching tile (64) a scalar tail would cost as much as the rest.
//
// Arithmetic stays in int16: v >> 4 lies in [-2048, 2047], so 2 v cannot overflow, and the
// saturating +- radius (a small number) only saturates where the reference's int result lies
// outside int16 too, which the clip to [dmin, dmax] (int16 values) then maps to the same bound.
//
// With narrow_lo (the temporal prior), the ranges of a second radius narrow_radius go to narrow_lo
// and narrow_hi in the same way, from the same extrema.
inline void PriorRangeSegment(const Plane<std::int16_t>& coarse, int cy, int x_begin, int x_end, int dmin, int dmax,
                              int radius, std::int16_t* HWY_RESTRICT lo_out, std::int16_t* HWY_RESTRICT hi_out,
                              int narrow_radius = 0, std::int16_t* HWY_RESTRICT narrow_lo = nullptr,
                              std::int16_t* HWY_RESTRICT narrow_hi = nullptr) {
  namespace hn = hwy::HWY_NAMESPACE;
  // Coarse columns per pass; their column minima and maxima live in stack arrays. Vectors are at
  // most 64 bytes: the slack every Plane row has past its end.
  constexpr int kChunk = 256;
  constexpr int kMaxLanes = 32;
  const hn::CappedTag<std::int16_t, kMaxLanes> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int cw = coarse.width(), ch = coarse.height();
  const std::int16_t* above = coarse.row(clamp_index(cy - 1, ch));
  const std::int16_t* centre = coarse.row(cy);
  const std::int16_t* below = coarse.row(clamp_index(cy + 1, ch));
  const auto invalid = hn::Set(d, kInvalid);
  const auto vmin = hn::Set(d, static_cast<std::int16_t>(dmin));
  const auto vmax = hn::Set(d, static_cast<std::int16_t>(dmax));
  const auto vr = hn::Set(d, static_cast<std::int16_t>(std::clamp(radius, -32768, 32767)));
  // Index 0 holds coarse column c0 - 1; vectors may run up to a vector past the last entry needed.
  HWY_ALIGN std::int16_t col_min[kChunk + 2 + kMaxLanes];
  HWY_ALIGN std::int16_t col_max[kChunk + 2 + kMaxLanes];
  HWY_ALIGN std::int16_t lo_buf[kChunk + kMaxLanes];
  HWY_ALIGN std::int16_t hi_buf[kChunk + kMaxLanes];
  HWY_ALIGN std::int16_t narrow_lo_buf[kChunk + kMaxLanes];
  HWY_ALIGN std::int16_t narrow_hi_buf[kChunk + kMaxLanes];
  const bool narrow = narrow_lo != nullptr;
  const auto vnr = hn::Set(d, static_cast<std::int16_t>(std::clamp(narrow_radius, -32768, 32767)));

  const int c_first = std::min(x_begin / 2, cw - 1), c_last = std::min((x_end - 1) / 2, cw - 1);
  int c0 = c_first;
  for (;; c0 += kChunk) {
    const int c1 = std::min(c0 + kChunk, c_last + 1);
    ThreeRowExtrema(d, above, centre, below, std::max(c0 - 1, 0), std::min(c1 + 1, cw), c0 - 1, col_min, col_max);
    if (c0 == 0) col_min[0] = col_min[1], col_max[0] = col_max[1];  // column -1 repeats column 0
    if (c1 == cw) col_min[cw - c0 + 1] = col_min[cw - c0], col_max[cw - c0 + 1] = col_max[cw - c0];

    for (int k = c0; k < c1; k += n) {
      const auto mn = ThreeColumnMin(d, col_min, k - c0 + 1), mx = ThreeColumnMax(d, col_max, k - c0 + 1);
      const auto mn_px = hn::ShiftRight<4>(mn), mx_px = hn::ShiftRight<4>(mx);  // floor, as v >> 4
      const auto lo = hn::Min(hn::Max(vmin, hn::SaturatedSub(hn::Add(mn_px, mn_px), vr)), vmax);
      const auto hi = hn::Max(hn::Min(vmax, hn::SaturatedAdd(hn::Add(mx_px, mx_px), vr)), vmin);
      const auto prior_invalid = hn::Eq(hn::LoadU(d, centre + k), invalid);
      hn::StoreU(hn::IfThenElse(prior_invalid, vmin, lo), d, lo_buf + (k - c0));
      hn::StoreU(hn::IfThenElse(prior_invalid, vmax, hi), d, hi_buf + (k - c0));
      if (narrow) {
        const auto nlo = hn::Min(hn::Max(vmin, hn::SaturatedSub(hn::Add(mn_px, mn_px), vnr)), vmax);
        const auto nhi = hn::Max(hn::Min(vmax, hn::SaturatedAdd(hn::Add(mx_px, mx_px), vnr)), vmin);
        hn::StoreU(hn::IfThenElse(prior_invalid, vmin, nlo), d, narrow_lo_buf + (k - c0));
        hn::StoreU(hn::IfThenElse(prior_invalid, vmax, nhi), d, narrow_hi_buf + (k - c0));
      }
    }

    // Coarse column k covers the fine columns 2k and 2k + 1.
    // The vectors past c1 carry values of no coarse column; a later pass or the slack takes them.
    const int x_end_here = std::min(2 * c1, x_end);
    for (int k = std::max(x_begin, 2 * c0) / 2; 2 * k < x_end_here; k += n) {
      const auto l = hn::LoadU(d, lo_buf + (k - c0)), u = hn::LoadU(d, hi_buf + (k - c0));
      hn::StoreInterleaved2(l, l, d, lo_out + (2 * k - x_begin));
      hn::StoreInterleaved2(u, u, d, hi_out + (2 * k - x_begin));
      if (narrow) {
        const auto nl = hn::LoadU(d, narrow_lo_buf + (k - c0)), nu = hn::LoadU(d, narrow_hi_buf + (k - c0));
        hn::StoreInterleaved2(nl, nl, d, narrow_lo + (2 * k - x_begin));
        hn::StoreInterleaved2(nu, nu, d, narrow_hi + (2 * k - x_begin));
      }
    }
    if (c1 > c_last) break;
  }
  // Fine columns past 2 cw (an odd width over a coarse level of floor(W / 2)) read column cw - 1,
  // which the last pass holds.
  for (int x = std::max(x_begin, 2 * cw); x < x_end; ++x) {
    lo_out[x - x_begin] = lo_buf[cw - 1 - c0];
    hi_out[x - x_begin] = hi_buf[cw - 1 - c0];
    if (narrow) {
      narrow_lo[x - x_begin] = narrow_lo_buf[cw - 1 - c0];
      narrow_hi[x - x_begin] = narrow_hi_buf[cw - 1 - c0];
    }
  }
}

/// Longest segment TemporalRangeSegment takes.
inline constexpr int kTemporalSegment = 256;

// The temporal prior (with_temporal_prior() of stages.hpp, vectorised) over the columns
// [x_begin, x_end) of row y, at most kTemporalSegment of them: band_lo / band_hi hold the coarser
// map's band (the level's radius), narrow_lo / narrow_hi its band of the temporal radius, all
// indexed from x_begin; the result goes to lo_out / hi_out. Whole vectors are written, up to
// kRangeSegmentSlack values past x_end, as PriorRangeSegment does; the inputs are read as far.
//
// The previous frame's band: kInvalid (INT16_MIN) never wins a maximum over a valid value and is
// replaced by INT16_MAX for the minimum; (max + 15) >> 4 cannot overflow (max <= 32767 - 15 for
// any valid Q4 value, and a column of invalid values only matters where the centre is invalid,
// whose result is discarded). The images' values are promoted to int16, where |a - b| <= 255.
inline void TemporalRangeSegment(const TemporalPrior& t, int y, int x_begin, int x_end, int dmin, int dmax,
                                 const std::int16_t* HWY_RESTRICT band_lo, const std::int16_t* HWY_RESTRICT band_hi,
                                 const std::int16_t* HWY_RESTRICT narrow_lo, const std::int16_t* HWY_RESTRICT narrow_hi,
                                 std::int16_t* HWY_RESTRICT lo_out, std::int16_t* HWY_RESTRICT hi_out) {
  namespace hn = hwy::HWY_NAMESPACE;
  constexpr int kMaxLanes = 32;
  const hn::CappedTag<std::int16_t, kMaxLanes> d;
  const int n = static_cast<int>(hn::Lanes(d));
  const hn::Rebind<std::uint8_t, decltype(d)> d8;
  const Plane<std::int16_t>& previous = *t.map;
  const int w = previous.width(), h = previous.height();
  const std::int16_t* above = previous.row(clamp_index(y - 1, h));
  const std::int16_t* centre = previous.row(y);
  const std::int16_t* below = previous.row(clamp_index(y + 1, h));
  const std::uint8_t* image = t.image->row(y);
  const std::uint8_t* previous_image = t.previous_image->row(y);
  const auto threshold = hn::Set(d, static_cast<std::int16_t>(t.threshold));
  const auto invalid = hn::Set(d, kInvalid);
  const auto vmin = hn::Set(d, static_cast<std::int16_t>(dmin));
  const auto vmax = hn::Set(d, static_cast<std::int16_t>(dmax));
  const auto vr = hn::Set(d, static_cast<std::int16_t>(t.radius));
  // Column extrema of the columns x_begin - 1 .. x_end (clamped to the image); index 0 holds
  // column x_begin - 1. Vectors may run a vector past the last entry needed.
  HWY_ALIGN std::int16_t col_min[kTemporalSegment + 2 + kMaxLanes];
  HWY_ALIGN std::int16_t col_max[kTemporalSegment + 2 + kMaxLanes];
  ThreeRowExtrema(d, above, centre, below, std::max(x_begin - 1, 0), std::min(x_end + 1, w), x_begin - 1, col_min,
                  col_max);
  if (x_begin == 0) col_min[0] = col_min[1], col_max[0] = col_max[1];  // column -1 repeats column 0
  if (x_end == w) col_min[w - x_begin + 1] = col_min[w - x_begin], col_max[w - x_begin + 1] = col_max[w - x_begin];

  for (int x = x_begin; x < x_end; x += n) {
    const auto mn = ThreeColumnMin(d, col_min, x - x_begin + 1), mx = ThreeColumnMax(d, col_max, x - x_begin + 1);
    const auto mn_px = hn::ShiftRight<4>(mn);                                  // floor, as v >> 4
    const auto mx_px = hn::ShiftRight<4>(hn::Add(mx, hn::Set(d, int16_t{15})));  // ceiling
    const auto t_lo = hn::Min(hn::Max(vmin, hn::Sub(mn_px, vr)), vmax);
    const auto t_hi = hn::Max(hn::Min(vmax, hn::Add(mx_px, vr)), vmin);
    const int o = x - x_begin;
    const auto c_lo = hn::LoadU(d, band_lo + o), c_hi = hn::LoadU(d, band_hi + o);
    // The previous band is used where its centre is valid, the pixel has not moved and the band
    // lies inside the coarser one.
    const auto change = hn::Abs(hn::Sub(hn::PromoteTo(d, hn::LoadU(d8, image + x)),
                                        hn::PromoteTo(d, hn::LoadU(d8, previous_image + x))));
    const auto outside = hn::Or(hn::Or(hn::Lt(t_lo, c_lo), hn::Gt(t_hi, c_hi)),  //
                                hn::Gt(change, threshold));
    const auto use = hn::AndNot(outside, hn::Ne(hn::LoadU(d, centre + x), invalid));
    const auto lo = hn::Min(hn::LoadU(d, narrow_lo + o), t_lo), hi = hn::Max(hn::LoadU(d, narrow_hi + o), t_hi);
    hn::StoreU(hn::IfThenElse(use, lo, c_lo), d, lo_out + o);
    hn::StoreU(hn::IfThenElse(use, hi, c_hi), d, hi_out + o);
  }
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
