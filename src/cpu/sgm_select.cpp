// Winners on the band SGM sums: the left view with Highway SIMD over each pixel's candidates, the
// right view by visiting every left candidate once per row (S_R(x - d, d) = S(x, d)), OpenMP over
// rows.
// Right-view sums fit u16 (below kSgmInf) and disparities int16 (|d| < 2048).
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/sgm_select.cpp"
#ifndef HWY_WANT_AVX3_DL
#define HWY_WANT_AVX3_DL
#endif
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <omp.h>

#include <algorithm>
#include <climits>

#include "cpu/parallel.hpp"
#include "cpu/sgm_segments.hpp"
#include "stages.hpp"


#include "cpu/min_lanes-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DU16 = MinTagU16;

// Pixels x, x + kRightPhases, ... are visited one after the other: neighbouring left pixels
// update overlapping runs of right pixels, and a vector load that overlaps a store still in
// flight cannot be forwarded from it (a stall of some 15 cycles on x86, at every pixel when they
// come in order). The order of the visits no longer gives ties to the smaller d, so the update
// compares disparities explicitly.
constexpr int kRightPhases = 16;

// The right view's winners of row y. Left pixel x's candidates lo + k go to the right pixels
// x - lo - k: reversed, a vector of them is a run of consecutive right pixels, whose running best
// sum and disparity (and then the neighbours' sums and the second best) one vector read-modify-
// write updates. Entries past a pixel's count are kSgmInf: they never win (a strict "<" against
// an initial kSgmInf) and never lower a minimum; the runs that reach left of pixel 0 land in
// front padding.
void SelectRightRow(const SgmVolume& v, const SgmSelectConfig& config, int y, std::uint16_t* rows,
                    std::int16_t* out) {
  const DU16 d;
  const hn::RebindToSigned<DU16> di;
  const int n = static_cast<int>(hn::Lanes(d));
  const int w = v.width, pad = right_row_pad(v.stride), len = w + 2 * pad;
  std::uint16_t* best_sum = rows + pad;
  std::int16_t* best_d = reinterpret_cast<std::int16_t*>(rows + len + pad);
  std::uint16_t* second = rows + 2 * len + pad;
  std::uint16_t* cm1 = rows + 3 * len + pad;
  std::uint16_t* cp1 = rows + 4 * len + pad;
  std::fill_n(rows, 5 * len, kSgmInf);
  const auto inf = hn::Set(d, kSgmInf);
  const auto lane = hn::Iota(di, 0);
  // The second pass only serves the uniqueness test (the second best) and sub-pixel (the
  // neighbours' sums): without them it is skipped, and each stream it does not need.
  const bool need_second = config.uniqueness_ratio > 0, need_neighbours = config.subpixel;
  const int passes = need_second || need_neighbours ? 2 : 1;
  const std::int16_t* lo_row = v.lo.row(y);
  const std::int16_t* count_row = v.count.row(y);
  const std::uint16_t* sum_row = v.sum_at(0, y);
  const int stride = v.stride;
  for (int pass = 0; pass < passes; ++pass) {
    for (int x_phase = 0; x_phase < kRightPhases; ++x_phase) {
      for (int x = x_phase; x < w; x += kRightPhases) {
        const int lo = lo_row[x], count = count_row[x];
        const std::uint16_t* sum = sum_row + static_cast<std::size_t>(x) * stride;
        for (int k0 = 0; k0 < count; k0 += n) {
          const int xr0 = x - lo - k0 - (n - 1);  // the right pixel of lane 0 (candidate k0 + n - 1)
          const auto s = hn::Reverse(d, hn::LoadU(d, sum + k0));
          const auto dv = hn::Sub(hn::Set(di, static_cast<std::int16_t>(x - xr0)), lane);  // d = x - xr
          if (pass == 0) {
            const auto old = hn::LoadU(d, best_sum + xr0);
            const auto old_d = hn::LoadU(di, best_d + xr0);
            const auto better = hn::Or(hn::RebindMask(di, hn::Lt(s, old)),
                                       hn::And(hn::RebindMask(di, hn::Eq(s, old)), hn::Lt(dv, old_d)));
            hn::StoreU(hn::Min(s, old), d, best_sum + xr0);
            hn::StoreU(hn::IfThenElse(better, dv, old_d), di, best_d + xr0);
            continue;
          }
          const auto delta = hn::Sub(dv, hn::LoadU(di, best_d + xr0));
          if (need_neighbours) {
            const auto present = hn::RebindMask(di, hn::Lt(s, inf));
            const auto below = hn::And(present, hn::Eq(delta, hn::Set(di, -1)));
            const auto above = hn::And(present, hn::Eq(delta, hn::Set(di, 1)));
            hn::StoreU(hn::IfThenElse(hn::RebindMask(d, below), s, hn::LoadU(d, cm1 + xr0)), d, cm1 + xr0);
            hn::StoreU(hn::IfThenElse(hn::RebindMask(d, above), s, hn::LoadU(d, cp1 + xr0)), d, cp1 + xr0);
          }
          if (need_second) {
            const auto far = hn::Or(hn::Lt(delta, hn::Set(di, -1)), hn::Gt(delta, hn::Set(di, 1)));
            const auto sec = hn::LoadU(d, second + xr0);
            hn::StoreU(hn::IfThenElse(hn::RebindMask(d, far), hn::Min(sec, s), sec), d, second + xr0);
          }
        }
      }
    }
  }
  for (int x = 0; x < w; ++x) {
    if (best_sum[x] == kSgmInf) {
      out[x] = kInvalid;
      continue;
    }
    const int sec = second[x] == kSgmInf ? INT_MAX : second[x];
    const int below = cm1[x] == kSgmInf ? -1 : cm1[x], above = cp1[x] == kSgmInf ? -1 : cp1[x];
    out[x] = sgm_winner_q4(best_d[x], best_sum[x], sec, below, above, config);
  }
}

// The left winner of one pixel. Out-of-band entries are kSgmInf, above every in-band sum, so the
// minimum over the whole slot is the minimum over the band.
template <class D>
HWY_INLINE std::int16_t SelectLeft(const std::uint16_t* sum, int lo, int count, int stride,
                                   const SgmSelectConfig& config, std::uint8_t* margin) {
  const D d;
  const int n = static_cast<int>(hn::Lanes(d));
  if (count == 0) {
    if (margin) *margin = 0;
    return kInvalid;
  }
  int best = 0, best_sum;
  if (stride == n) {
    best_sum = FirstMinLane(d, hn::LoadU(d, sum), best);
  } else {
    auto vmin = hn::LoadU(d, sum);
    for (int k = n; k < stride; k += n) vmin = hn::Min(vmin, hn::LoadU(d, sum + k));
    best_sum = MinLaneOf(d, vmin);
    const auto all_min = hn::Set(d, static_cast<std::uint16_t>(best_sum));
    for (int k = 0; k < stride; k += n) {
      const intptr_t i = hn::FindFirstTrue(d, hn::Eq(hn::LoadU(d, sum + k), all_min));
      if (i >= 0) {
        best = k + static_cast<int>(i);
        break;
      }
    }
  }
  // Second best outside best - 1 .. best + 1: lanes k with (k - best + 1) mod 2^16 <= 2 excluded.
  const auto inf = hn::Set(d, kSgmInf);
  const auto two = hn::Set(d, 2);
  auto vsec = inf;
  for (int k = 0; k < stride; k += n) {
    const auto rel = hn::Iota(d, static_cast<std::uint16_t>(k - best + 1));
    const auto near = hn::Not(hn::Lt(two, rel));  // rel <= 2 (unsigned)
    vsec = hn::Min(vsec, hn::IfThenElse(near, inf, hn::LoadU(d, sum + k)));
  }
  const int sec_raw = MinLaneOf(d, vsec);
  const int second = sec_raw == kSgmInf ? INT_MAX : sec_raw;
  const int cm1 = best > 0 ? sum[best - 1] : -1;
  const int cp1 = best + 1 < count ? sum[best + 1] : -1;
  if (margin) *margin = sgm_margin_fast(best_sum, second, cm1 >= 0 && cp1 >= 0);
  return sgm_winner_q4(lo + best, best_sum, second, cm1, cp1, config);
}

// The left winners (and margins) of row y, slots read by vectors of tag D.
template <class D>
void SelectLeftRow(const SgmVolume& v, const SgmSelectConfig& config, int y, std::int16_t* out, std::uint8_t* m) {
  // Row pointers and the stride in locals: the margin stores go through a byte pointer, which
  // may alias anything, and would make the compiler reload them at every pixel.
  const std::int16_t* lo = v.lo.row(y);
  const std::int16_t* count = v.count.row(y);
  const std::uint16_t* sum = v.sum_at(0, y);
  const int w = v.width, stride = v.stride;
  for (int x = 0; x < w; ++x)
    out[x] = SelectLeft<D>(sum + static_cast<std::size_t>(x) * stride, lo[x], count[x], stride, config,
                           m ? m + x : nullptr);
}

void SgmSelectRows(const SgmVolume& v, const SgmSelectConfig& config, SgmScratch& scratch, Plane<std::int16_t>& left,
                   Plane<std::int16_t>* right, Plane<std::uint8_t>* margin, int first, int last) {
  if (t_pool && t_pool->size() > scratch.threads) std::abort();  // a scratch slice per thread
  const auto select_left = WideSlots(v.stride) ? &SelectLeftRow<WideTagU16> : &SelectLeftRow<DU16>;
  parallel_for(
      last - first, 4,
      [&](int i0, int i1) {
        const int y0 = first + i0, y1 = first + i1;
        auto* rows =
            reinterpret_cast<std::uint16_t*>(scratch.data.get() + thread_slot() * scratch.bytes_per_thread);
        for (int y = y0; y < y1; ++y) {
          select_left(v, config, y, left.row(y), margin ? margin->row(y) : nullptr);
          if (right) SelectRightRow(v, config, y, rows, right->row(y));
        }
      },
      scratch.threads);
}

void SgmSelect(const SgmVolume& v, const SgmSelectConfig& config, SgmScratch& scratch, Plane<std::int16_t>& left,
               Plane<std::int16_t>* right, Plane<std::uint8_t>* margin) {
  SgmSelectRows(v, config, scratch, left, right, margin, 0, v.height);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(SgmSelect);
HWY_EXPORT(SgmSelectRows);
void sgm_select_rows(const SgmVolume& volume, const SgmSelectConfig& config, SgmScratch& scratch,
                     Plane<std::int16_t>& left, Plane<std::int16_t>* right, Plane<std::uint8_t>* margin, int first,
                     int last) {
  HWY_DYNAMIC_DISPATCH(SgmSelectRows)(volume, config, scratch, left, right, margin, first, last);
}
void sgm_select(const SgmVolume& volume, const SgmSelectConfig& config, SgmScratch& scratch,
                Plane<std::int16_t>& left, Plane<std::int16_t>* right, Plane<std::uint8_t>* margin) {
  HWY_DYNAMIC_DISPATCH(SgmSelect)(volume, config, scratch, left, right, margin);
}
}  // namespace mctstereo::detail::cpu
#endif
