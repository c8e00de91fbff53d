// Winners on the band SGM sums: the left view with Highway SIMD over each pixel's candidates, the
// right view by visiting every left candidate once per row (S_R(x - d, d) = S(x, d)), OpenMP over
// rows. Along a row the left pixels come in increasing x, so each right pixel meets its
// candidates in increasing d and a strict "<" keeps the smaller d on ties, as the reference.
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

#include "stages.hpp"

#ifndef MCTSTEREO_CPU_SGM_SELECT_ONCE
#define MCTSTEREO_CPU_SGM_SELECT_ONCE
namespace mctstereo::detail::cpu {

// Uniqueness, sub-pixel and the Q4 value from a winner's terms (cm1, cp1 < 0: not a candidate;
// second == INT_MAX: no candidate outside best - 1 .. best + 1), as the reference's select_one.
inline std::int16_t finish_winner(int best, int best_sum, int second, int cm1, int cp1, const SgmSelectConfig& config) {
  if (config.uniqueness_ratio > 0 && second != INT_MAX && 100 * (second - best_sum) <= config.uniqueness_ratio * best_sum)
    return kInvalid;
  int q4 = 16 * best;
  if (config.subpixel && cm1 >= 0 && cp1 >= 0) q4 += subpixel_offset_q4(cm1, best_sum, cp1);
  return static_cast<std::int16_t>(q4);
}

inline std::uint8_t margin_of(int best_sum, int second) {
  return second != INT_MAX && second > 0 ? static_cast<std::uint8_t>(255 * (second - best_sum) / second) : 0;
}

// The right view's winners of row y.
inline void select_right_row(const SgmVolume& v, const SgmSelectConfig& config, int y, int* rows,
                             std::int16_t* out) {
  const int w = v.width;
  int* best_sum = rows;
  int* best_d = rows + w;
  int* second = rows + 2 * w;
  int* cm1 = rows + 3 * w;
  int* cp1 = rows + 4 * w;
  std::fill_n(best_sum, w, INT_MAX);
  std::fill_n(second, w, INT_MAX);
  std::fill_n(cm1, w, -1);
  std::fill_n(cp1, w, -1);
  for (int x = 0; x < w; ++x) {
    const int lo = v.lo.at(x, y), count = v.count.at(x, y);
    const std::uint16_t* sum = v.sum_at(x, y);
    for (int k = 0; k < count; ++k) {
      const int xr = x - lo - k;  // in [0, W): the band holds only candidates inside the image
      // Selects, not branches: whether a candidate wins is data, and mispredicted it costs more.
      const bool better = sum[k] < best_sum[xr];
      best_d[xr] = better ? lo + k : best_d[xr];
      best_sum[xr] = better ? sum[k] : best_sum[xr];
    }
  }
  for (int x = 0; x < w; ++x) {
    const int lo = v.lo.at(x, y), count = v.count.at(x, y);
    const std::uint16_t* sum = v.sum_at(x, y);
    for (int k = 0; k < count; ++k) {
      const int d = lo + k, xr = x - d, delta = d - best_d[xr], value = sum[k];
      cm1[xr] = delta == -1 ? value : cm1[xr];
      cp1[xr] = delta == 1 ? value : cp1[xr];
      second[xr] = delta < -1 || delta > 1 ? std::min(second[xr], value) : second[xr];
    }
  }
  for (int x = 0; x < w; ++x)
    out[x] = best_sum[x] == INT_MAX ? kInvalid : finish_winner(best_d[x], best_sum[x], second[x], cm1[x], cp1[x], config);
}

}  // namespace mctstereo::detail::cpu
#endif

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DU16 = hn::CappedTag<std::uint16_t, 16>;

// The left winner of one pixel. Out-of-band entries are kSgmInf, above every in-band sum, so the
// minimum over the whole slot is the minimum over the band.
HWY_INLINE std::int16_t SelectLeft(const std::uint16_t* sum, int lo, int count, int stride,
                                   const SgmSelectConfig& config, std::uint8_t* margin) {
  const DU16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  if (count == 0) {
    if (margin) *margin = 0;
    return kInvalid;
  }
  auto vmin = hn::LoadU(d, sum);
  for (int k = n; k < stride; k += n) vmin = hn::Min(vmin, hn::LoadU(d, sum + k));
  const auto all_min = hn::MinOfLanes(d, vmin);
  const int best_sum = hn::GetLane(all_min);
  int best = 0;
  for (int k = 0; k < stride; k += n) {
    const intptr_t i = hn::FindFirstTrue(d, hn::Eq(hn::LoadU(d, sum + k), all_min));
    if (i >= 0) {
      best = k + static_cast<int>(i);
      break;
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
  const int sec_raw = hn::GetLane(hn::MinOfLanes(d, vsec));
  const int second = sec_raw == kSgmInf ? INT_MAX : sec_raw;
  if (margin) *margin = margin_of(best_sum, second);
  const int cm1 = best > 0 ? sum[best - 1] : -1;
  const int cp1 = best + 1 < count ? sum[best + 1] : -1;
  return finish_winner(lo + best, best_sum, second, cm1, cp1, config);
}

void SgmSelect(const SgmVolume& v, const SgmSelectConfig& config, SgmScratch& scratch, Plane<std::int16_t>& left,
               Plane<std::int16_t>* right, Plane<std::uint8_t>* margin) {
  const int w = v.width, h = v.height;
#pragma omp parallel num_threads(scratch.threads)
  {
    int* rows = reinterpret_cast<int*>(scratch.data.get() + omp_get_thread_num() * scratch.bytes_per_thread);
#pragma omp for schedule(dynamic, 4)
    for (int y = 0; y < h; ++y) {
      std::int16_t* out = left.row(y);
      std::uint8_t* m = margin ? margin->row(y) : nullptr;
      for (int x = 0; x < w; ++x)
        out[x] = SelectLeft(v.sum_at(x, y), v.lo.at(x, y), v.count.at(x, y), v.stride, config, m ? m + x : nullptr);
      if (right) select_right_row(v, config, y, rows, right->row(y));
    }
  }
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(SgmSelect);
void sgm_select(const SgmVolume& volume, const SgmSelectConfig& config, SgmScratch& scratch,
                Plane<std::int16_t>& left, Plane<std::int16_t>* right, Plane<std::uint8_t>* margin) {
  HWY_DYNAMIC_DISPATCH(SgmSelect)(volume, config, scratch, left, right, margin);
}
}  // namespace mctstereo::detail::cpu
#endif
