// The Q4 map in the caller's convention (kInvalid -> (dmin - 1) x 16), with Highway SIMD: the
// library's own code outside the dispatched stages is built for the baseline target (SSE2 on
// x86-64), where this pass took 4 % of a realtime frame at 640 x 480.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/output_q4.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cstdint>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

void OutputQ4(const Plane<std::int16_t>& src, std::int16_t invalid_q4, Plane<std::int16_t>& dst) {
  // At most 32 lanes: the last vector of a row may run into the rows' 64-byte slack.
  const hn::CappedTag<std::int16_t, 32> d;
  const int w = dst.width(), n = static_cast<int>(hn::Lanes(d));
  const auto invalid = hn::Set(d, kInvalid), replacement = hn::Set(d, invalid_q4);
  parallel_lines(dst.height(), [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const std::int16_t* s = src.row(y);
      std::int16_t* o = dst.row(y);
      int x = 0;
      for (; x + n <= w; x += n) {
        const auto v = hn::LoadU(d, s + x);
        hn::StoreU(hn::IfThenElse(hn::Eq(v, invalid), replacement, v), d, o + x);
      }
      for (; x < w; ++x) o[x] = s[x] == kInvalid ? invalid_q4 : s[x];
    }
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(OutputQ4);
void output_q4(const Plane<std::int16_t>& src, std::int16_t invalid_q4, Plane<std::int16_t>& dst) {
  HWY_DYNAMIC_DISPATCH(OutputQ4)(src, invalid_q4, dst);
}
}  // namespace mctstereo::detail::cpu
#endif
