// Left-right consistency check of one row, per SIMD target (lr_check.cpp and the finest level's
// refinement in strips, refine_left_map.cpp, share it): each pixel compares its disparity with the other view's at the
// pixel its own (rounded) disparity points to.
//
// A gather would fetch those pixels directly, but gathers are slow on many x86 cores (measured on
// an AMD EPYC: 0.54 ms per 640 x 480 map, no faster than the scalar loop). Disparity maps are
// smooth, though: the rounded disparities k of one vector of pixels span only a few values. So
// for each k from the vector's smallest to its largest, one unaligned load of the other row
// shifted by k serves every lane whose disparity rounds to k. Vectors spanning more than
// kMaxSpan values (noise), or whose shifted loads would leave the row and its slack, take the
// scalar loop of the reference instead. A span up to kMaxSpan (a depth edge inside the vector)
// costs one load and a select per value, still well below the scalar loop's 32 pixels.
// The first vectors of a row point before its start wherever their disparities exceed x: they
// read a copy of the row's start behind kFront invalid entries, which fail the check as a
// partner outside the image does.
// Included after <hwy/highway.h> by files that use foreach_target.h; the toggled guard is
// Highway's idiom for that.
#if defined(MCTSTEREO_CPU_LR_CHECK_ROW_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_LR_CHECK_ROW_INL_H_
#undef MCTSTEREO_CPU_LR_CHECK_ROW_INL_H_
#else
#define MCTSTEREO_CPU_LR_CHECK_ROW_INL_H_
#endif

#include <hwy/highway.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include "cpu/min_lanes-inl.h"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

constexpr int kMaxSpan = 32;
constexpr int kFront = 64;         // invalid entries before the copy of a row's start
constexpr int kExtColumns = 128;   // columns of the row copied behind them
/// Entries of the buffer LrCheckRow copies a row's start into: kInvalid at first (LrExtInit).
constexpr int kLrExtEntries = kFront + kExtColumns + 32;

// The reference's rule for pixels [x0, x1) of a row.
HWY_INLINE void LrCheckScalar(const std::int16_t* s, const std::int16_t* o, int w, int x0, int x1, int dir,
                              int threshold_q4, std::int16_t* out) {
  for (int x = x0; x < x1; ++x) {
    const int v = s[x];
    std::int16_t r = kInvalid;
    if (v != kInvalid) {
      const int xo = x + dir * ((v + 8) >> 4);
      if (xo >= 0 && xo < w && o[xo] != kInvalid && std::abs(v - o[xo]) <= threshold_q4)
        r = static_cast<std::int16_t>(v);
    }
    out[x] = r;
  }
}

HWY_INLINE void LrExtInit(std::int16_t* ext) { std::fill_n(ext, kLrExtEntries, kInvalid); }

// One row: s, o and out w wide, s and o with the planes' 64 bytes of slack after w; ext: a
// buffer of kLrExtEntries (64-byte aligned) that LrExtInit filled. Entries past the copied
// columns (rows narrower than kExtColumns) stay invalid; loads reach at most a vector past
// kExtColumns.
HWY_INLINE void LrCheckRow(const std::int16_t* s, const std::int16_t* o, int w, int dir, int threshold_q4,
                           std::int16_t* out, std::int16_t* ext) {
  // At most 32 lanes: a load shifted to end at most a vector past the row stays in its 64-byte
  // slack (checked per vector below).
  const hn::CappedTag<std::int16_t, 32> d;
  const hn::RebindToUnsigned<decltype(d)> du;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto invalid = hn::Set(d, kInvalid);
  const auto one = hn::Set(d, 1);
  // |v - u| <= t for int16 v, u: computed as the unsigned difference of the larger and the smaller
  // (exact for every pair); a threshold beyond int16 keeps every pair.
  const auto threshold = hn::Set(du, static_cast<std::uint16_t>(std::min(threshold_q4, 65535)));
  const int slack = 64 / static_cast<int>(sizeof(std::int16_t));
  // Partner columns x + i + dir k of the vector path lie in [0, w + slack) and are formed in int16
  // lanes: wider maps (and a negative threshold, which keeps nothing) take the scalar loop.
  const bool vectors = w + slack <= INT16_MAX && threshold_q4 >= 0;
  const int vector_end = vectors ? w / n * n : 0;
  const int ext_columns = std::min(w, kExtColumns);
  bool ext_filled = false;  // whether ext holds this row's start
  for (int x = 0; x < vector_end; x += n) {
    const auto v = hn::LoadU(d, s + x);
    // (v + 8) >> 4 without the int16 overflow of v + 8: floor(v / 16) + (bit 3 of v).
    const auto k = hn::Add(hn::ShiftRight<4>(v), hn::And(hn::ShiftRight<3>(v), one));
    const auto valid = hn::Ne(v, invalid);
    if (hn::AllFalse(d, valid)) {
      hn::StoreU(invalid, d, out + x);
      continue;
    }
    // Lane i's partner o[x + i + dir k_i]; starts before column 0 read a copy of the row's start
    // behind kFront invalid entries.
    const auto row_start = [&] {
      if (!ext_filled) std::copy_n(o, ext_columns, ext + kFront);
      ext_filled = true;
      return static_cast<const std::int16_t*>(ext + kFront);
    };
    auto u = invalid;
    bool have_partners = false;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
    {
      // One two-table permute (VPERMT2W) fetches every lane's partner from the 64 entries of the
      // other row that start at the nearest partner, x - kmax (dir -1) or x + kmin (dir +1):
      // lane i reads entry i + dir (k_i - k_edge), which lies in [0, 63] wherever the vector's
      // span allows. One reduction instead of two and no loop over the span; vectors with a lane
      // out of that window take the shifted loads below.
      const int k_edge = dir < 0 ? MaxLaneI16(d, hn::IfThenElse(valid, k, hn::Set(d, INT16_MIN)))
                                 : MinLaneI16(d, hn::IfThenElse(valid, k, hn::Set(d, INT16_MAX)));
      const int first = x + dir * k_edge, last = first + 2 * n;  // the entries read
      const auto edge = hn::Set(d, static_cast<std::int16_t>(k_edge));
      const auto j = hn::Add(hn::Iota(d, 0), dir < 0 ? hn::Sub(edge, k) : hn::Sub(k, edge));
      const bool in_window = hn::AllFalse(d, hn::And(valid, hn::Gt(j, hn::Set(d, 2 * n - 1))));
      // Reads stay in the row and its slack, or in ext (whose used entries, first + j < 64, lie
      // in the copied columns: first < 0 there).
      if (in_window && last <= w + slack && (first >= 0 || (first >= -kFront && last <= kExtColumns + 32))) {
        const std::int16_t* table = first >= 0 ? o + first : row_start() + first;
        const auto lo = hn::LoadU(d, table), hi = hn::LoadU(d, table + n);
        u = decltype(u){_mm512_permutex2var_epi16(lo.raw, j.raw, hi.raw)};
        have_partners = true;
      }
    }
#endif
    if (!have_partners) {
      const int kmin = MinLaneI16(d, hn::IfThenElse(valid, k, hn::Set(d, INT16_MAX)));
      const int kmax = MaxLaneI16(d, hn::IfThenElse(valid, k, hn::Set(d, INT16_MIN)));
      // Lane i of the load for k reads o[x + i + dir k]: from x + dir k, n lanes.
      const int first = dir < 0 ? x - kmax : x + kmin;
      const int last = (dir < 0 ? x - kmin : x + kmax) + n;  // one past the last value read
      const bool before_row = first < 0;
      if (kmax - kmin >= kMaxSpan || last > w + slack ||
          (before_row && (first < -kFront || last > kExtColumns))) {
        LrCheckScalar(s, o, w, x, x + n, dir, threshold_q4, out);
        continue;
      }
      const std::int16_t* base = before_row ? row_start() : o;
      for (int kk = kmin; kk <= kmax; ++kk) {
        const auto shifted = hn::LoadU(d, base + x + dir * kk);
        u = hn::IfThenElse(hn::Eq(k, hn::Set(d, static_cast<std::int16_t>(kk))), shifted, u);
      }
    }
    // The partner must lie in the image: 0 <= x + i + dir k < w. Partners before column 0
    // read kInvalid from ext's front and fail below; the loads may reach into the slack
    // past w.
    const auto xo = hn::Add(hn::Iota(d, x), dir < 0 ? hn::Neg(k) : k);
    const auto inside = hn::Lt(xo, hn::Set(d, static_cast<std::int16_t>(w)));
    const auto diff = hn::Sub(hn::BitCast(du, hn::Max(v, u)), hn::BitCast(du, hn::Min(v, u)));
    const auto close = hn::RebindMask(d, hn::Not(hn::Gt(diff, threshold)));
    const auto keep = hn::And(hn::And(valid, inside), hn::And(hn::Ne(u, invalid), close));
    hn::StoreU(hn::IfThenElse(keep, v, invalid), d, out + x);
  }
  LrCheckScalar(s, o, w, vector_end, w, dir, threshold_q4, out);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
