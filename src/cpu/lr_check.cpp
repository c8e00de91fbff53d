// Left-right consistency check: each pixel gathers the other view's disparity at the pixel its own
// (rounded) disparity points to, in int32 lanes because x86 gathers have no 16-bit form.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/lr_check.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cstdint>
#include <cstdlib>

#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void LrCheck(const Plane<std::int16_t>& src, const Plane<std::int16_t>& other, int dir, int threshold_q4,
             Plane<std::int16_t>& dst) {
  const hn::ScalableTag<std::int32_t> d32;
  const hn::Rebind<std::int16_t, decltype(d32)> d16;  // the same lanes, half as wide
  const int w = src.width(), h = src.height();
  const int n = static_cast<int>(hn::Lanes(d32));
  const auto invalid = hn::Set(d32, kInvalid);
  const auto minus_one = hn::Set(d32, -1);
  const auto width = hn::Set(d32, w);
  const auto threshold = hn::Set(d32, threshold_q4);
  const auto eight = hn::Set(d32, 8);

#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    const std::int16_t* s = src.row(y);
    const std::int16_t* o = other.row(y);
    std::int16_t* out = dst.row(y);
    // The gather reads 32 bits at byte offset 2 xo and keeps the low half (x86 and Arm are little
    // endian), so it touches o[xo + 1] <= o[w], which lies in the row's slack.
    const std::int32_t* o32 = reinterpret_cast<const std::int32_t*>(o);
    const int vector_end = w / n * n;  // the rest is done one pixel at a time below
    for (int x = 0; x < vector_end; x += n) {
      const auto v = hn::PromoteTo(d32, hn::LoadU(d16, s + x));
      // (v + 8) >> 4 is the rounded disparity (arithmetic shift = floor, as in the reference).
      auto shift = hn::ShiftRight<4>(hn::Add(v, eight));
      if (dir < 0) shift = hn::Neg(shift);
      const auto xo = hn::Add(hn::Iota(d32, x), shift);
      const auto valid = hn::And(hn::Ne(v, invalid), hn::And(hn::Gt(xo, minus_one), hn::Lt(xo, width)));
      // Lanes without a partner read pixel 0 (always readable) and are rejected by `valid`.
      const auto g = hn::GatherOffset(d32, o32, hn::ShiftLeft<1>(hn::IfThenElseZero(valid, xo)));
      const auto u = hn::ShiftRight<16>(hn::ShiftLeft<16>(g));  // sign-extends the low 16 bits
      const auto agree = hn::AndNot(hn::Gt(hn::Abs(hn::Sub(v, u)), threshold), hn::Ne(u, invalid));
      hn::StoreU(hn::DemoteTo(d16, hn::IfThenElse(hn::And(valid, agree), v, invalid)), d16, out + x);
    }
    for (int x = vector_end; x < w; ++x) {
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
