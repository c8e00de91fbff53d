// pyramid_down with Highway SIMD: 5-tap binomial blur (1 4 6 4 1) in both directions, keeping the
// even pixels, (sum + 128) >> 8.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/pyramid.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/vec_slot-inl.h"

#include <algorithm>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Output columns per pass over a row; the column sums of a pass live in two stack arrays.
constexpr int kChunk = 512;
// u16 lanes of the widest vector used: 64 bytes, the slack every Plane row has past its end.
constexpr int kMaxLanes = 32;

// One output row. rows[0..4] are the source rows 2y-2 .. 2y+2 (already clamped).
//
// Pass 1 sums each source column vertically, V(c) = r0 + 4 r1 + 6 r2 + 4 r3 + r4 <= 16 * 255, and
// stores the even and odd columns apart, E[k] = V(2k) and O[k] = V(2k+1), so that pass 2 needs no
// shuffles: out(x) = E[x-1] + 4 O[x-1] + 6 E[x] + 4 O[x] + E[x+1] <= 256 * 255, and with the
// rounding term still < 2^16, so u16 lanes are exact throughout. Only E[-1], O[-1] (columns -2,
// -1) and the columns at or past the right edge need clamping; they are patched between the passes.
void DownRow(const std::uint8_t* const* rows, int src_width, int dst_width, std::uint8_t* HWY_RESTRICT dst) {
  const hn::CappedTag<std::uint16_t, kMaxLanes> d16;
  const hn::Rebind<std::uint8_t, decltype(d16)> d8;
  const hn::RebindToSigned<decltype(d16)> di16;
  const int n = static_cast<int>(hn::Lanes(d16));
  const auto four = hn::Set(d16, 4), six = hn::Set(d16, 6), half = hn::Set(d16, 128);
  // Index 0 holds column pair x0 - 1; vectors may run up to a vector past the last entry needed.
  HWY_ALIGN std::uint16_t even[kChunk + 2 + kMaxLanes];
  HWY_ALIGN std::uint16_t odd[kChunk + 2 + kMaxLanes];
  // Source column 2k lies inside the row exactly for k < ceil(W / 2) = dst_width.
  for (int x0 = 0; x0 < dst_width; x0 += kChunk) {
    const int x1 = std::min(x0 + kChunk, dst_width);
    const int k_end = std::min(x1 + 1, dst_width);
    // A load of 2n bytes from column 2k < W stays within the row's 64 bytes of slack.
    for (int k = std::max(x0 - 1, 0); k < k_end; k += n) {
      VecSlot<decltype(d8)> e8[5], o8[5];
      for (int i = 0; i < 5; ++i) {
        hn::Vec<decltype(d8)> e, o;
        hn::LoadInterleaved2(d8, rows[i] + 2 * k, e, o);
        e8[i] = e;
        o8[i] = o;
      }
      auto vsum = [&](const VecSlot<decltype(d8)>* v) {
        const auto wide = [&](int i) { return hn::PromoteTo(d16, hn::Vec<decltype(d8)>(v[i])); };
        const auto outer = hn::Add(wide(0), wide(4));
        const auto inner = hn::Add(wide(1), wide(3));
        return hn::Add(hn::Add(outer, hn::Mul(inner, four)), hn::Mul(wide(2), six));
      };
      hn::StoreU(vsum(e8), d16, even + (k - x0 + 1));
      hn::StoreU(vsum(o8), d16, odd + (k - x0 + 1));
    }
    if (x0 == 0) even[0] = odd[0] = even[1];  // columns -2 and -1 repeat column 0
    if (x1 == dst_width) {
      // Columns >= W repeat column W-1, which is E[dst_width-1] for odd W, O[dst_width-1] for even W.
      const int last = dst_width - 1 - x0 + 1;
      if (src_width % 2 == 1) {
        odd[last] = even[last];
        even[last + 1] = even[last];
      } else {
        even[last + 1] = odd[last];
      }
    }
    // The store of n bytes from x < dst_width stays within the destination row's slack.
    for (int x = x0; x < x1; x += n) {
      const int i = x - x0 + 1;
      const auto e_outer = hn::Add(hn::LoadU(d16, even + i - 1), hn::LoadU(d16, even + i + 1));
      const auto o_inner = hn::Add(hn::LoadU(d16, odd + i - 1), hn::LoadU(d16, odd + i));
      auto sum = hn::Add(hn::Add(e_outer, half), hn::Mul(o_inner, four));
      sum = hn::Add(sum, hn::Mul(hn::LoadU(d16, even + i), six));
      const auto y = hn::BitCast(di16, hn::ShiftRight<8>(sum));  // <= 255: exact demotion
      hn::StoreU(hn::DemoteTo(d8, y), d8, dst + x);
    }
  }
}

void PyramidDown(const Plane<std::uint8_t>& src, Plane<std::uint8_t>& dst) {
  const int w = src.width(), h = src.height();
  const int dw = dst.width(), dh = dst.height();
  if (dw == 0 || w == 0) return;
  parallel_lines(dh, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      const std::uint8_t* rows[5];
      for (int j = 0; j < 5; ++j) rows[j] = src.row(clamp_index(2 * y - 2 + j, h));
      DownRow(rows, w, dw, dst.row(y));
    }
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(PyramidDown);
void pyramid_down(const Plane<std::uint8_t>& src, Plane<std::uint8_t>& dst) {
  HWY_DYNAMIC_DISPATCH(PyramidDown)(src, dst);
}
}  // namespace mctstereo::detail::cpu
#endif
