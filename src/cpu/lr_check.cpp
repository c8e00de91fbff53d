// Left-right consistency check: each pixel compares its disparity with the other view's at the
// pixel its own (rounded) disparity points to.
//
// A gather would fetch those pixels directly, but gathers are slow on many x86 cores (measured on
// an AMD EPYC: 0.54 ms per 640 x 480 map, no faster than the scalar loop). Disparity maps are
// smooth, though: the rounded disparities k of one vector of pixels span only a few values. So
// for each k from the vector's smallest to its largest, one unaligned load of the other row
// shifted by k serves every lane whose disparity rounds to k. Vectors spanning more than
// kMaxSpan values (noise, depth edges), or whose shifted loads would leave the row and its slack,
// take the scalar loop of the reference instead.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/lr_check.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

constexpr int kMaxSpan = 8;

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

void LrCheck(const Plane<std::int16_t>& src, const Plane<std::int16_t>& other, int dir, int threshold_q4,
             Plane<std::int16_t>& dst) {
  // At most 32 lanes: a load shifted to end at most a vector past the row stays in its 64-byte
  // slack (checked per vector below).
  const hn::CappedTag<std::int16_t, 32> d;
  const hn::RebindToUnsigned<decltype(d)> du;
  const int w = src.width(), h = src.height();
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

  parallel_lines(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const std::int16_t* s = src.row(y);
      const std::int16_t* o = other.row(y);
      std::int16_t* out = dst.row(y);
      for (int x = 0; x < vector_end; x += n) {
        const auto v = hn::LoadU(d, s + x);
        // (v + 8) >> 4 without the int16 overflow of v + 8: floor(v / 16) + (bit 3 of v).
        const auto k = hn::Add(hn::ShiftRight<4>(v), hn::And(hn::ShiftRight<3>(v), one));
        const auto valid = hn::Ne(v, invalid);
        if (hn::AllFalse(d, valid)) {
          hn::StoreU(invalid, d, out + x);
          continue;
        }
        const int kmin = hn::GetLane(hn::MinOfLanes(d, hn::IfThenElse(valid, k, hn::Set(d, INT16_MAX))));
        const int kmax = hn::GetLane(hn::MaxOfLanes(d, hn::IfThenElse(valid, k, hn::Set(d, INT16_MIN))));
        // Lane i of the load for k reads o[x + i + dir k]: from x + dir k, n lanes.
        const int first = dir < 0 ? x - kmax : x + kmin;
        const int last = (dir < 0 ? x - kmin : x + kmax) + n;  // one past the last value read
        if (kmax - kmin >= kMaxSpan || first < 0 || last > w + slack) {
          LrCheckScalar(s, o, w, x, x + n, dir, threshold_q4, out);
          continue;
        }
        auto u = invalid;
        for (int kk = kmin; kk <= kmax; ++kk) {
          const auto shifted = hn::LoadU(d, o + x + dir * kk);
          u = hn::IfThenElse(hn::Eq(k, hn::Set(d, static_cast<std::int16_t>(kk))), shifted, u);
        }
        // The partner must lie in the image: 0 <= x + i + dir k < w. The first half holds for every
        // valid lane since first >= 0; the loads may reach into the slack past w.
        const auto xo = hn::Add(hn::Iota(d, x), dir < 0 ? hn::Neg(k) : k);
        const auto inside = hn::Lt(xo, hn::Set(d, static_cast<std::int16_t>(w)));
        const auto diff = hn::Sub(hn::BitCast(du, hn::Max(v, u)), hn::BitCast(du, hn::Min(v, u)));
        const auto close = hn::RebindMask(d, hn::Not(hn::Gt(diff, threshold)));
        const auto keep = hn::And(hn::And(valid, inside), hn::And(hn::Ne(u, invalid), close));
        hn::StoreU(hn::IfThenElse(keep, v, invalid), d, out + x);
      }
      LrCheckScalar(s, o, w, vector_end, w, dir, threshold_q4, out);
    }
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
