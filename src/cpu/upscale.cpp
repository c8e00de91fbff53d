// upscale with Highway SIMD: each pixel replicated factor x factor, its value times factor and
// clamped to [lo_q4, hi_q4]; invalid stays invalid.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/upscale.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstring>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// i16 lanes of the widest vector used: 64 bytes, the slack every Plane row has past its end.
constexpr int kMaxLanes = 32;

using D16 = hn::CappedTag<std::int16_t, kMaxLanes>;

// One output row from one source row. The product v * factor can leave int16, so it is formed in
// int32 lanes; after the clamp to [lo_q4, hi_q4] (int16 values) the demotion is exact.
void UpscaleRow(const std::int16_t* HWY_RESTRICT src, int factor, int lo_q4, int hi_q4, int out_width,
                std::int16_t* HWY_RESTRICT dst) {
  int sx = 0;
#if HWY_TARGET != HWY_SCALAR  // one lane per vector: the scalar loop below does it all
  const D16 d;
  const hn::Repartition<std::int32_t, D16> d32;
  const hn::Rebind<std::int16_t, decltype(d32)> dh;
  const int n = static_cast<int>(hn::Lanes(d));
  const int nh = static_cast<int>(hn::Lanes(d32));
  const auto invalid = hn::Set(d, kInvalid);
  const auto vf = hn::Set(d32, factor), vlo = hn::Set(d32, lo_q4), vhi = hn::Set(d32, hi_q4);
  auto scaled = [&](const std::int16_t* p) {
    return hn::DemoteTo(dh, hn::Min(hn::Max(hn::Mul(hn::PromoteTo(d32, hn::LoadU(dh, p)), vf), vlo), vhi));
  };
  // Whole vectors while their factor * n outputs fit in the row; the rest is scalar.
  if (factor == 1 || factor == 2 || factor == 4) {
    for (; (sx + n) * factor <= out_width; sx += n) {
      const auto v = hn::LoadU(d, src + sx);
      const auto t = hn::IfThenElse(hn::Eq(v, invalid), invalid,
                                    hn::Combine(d, scaled(src + sx + nh), scaled(src + sx)));
      std::int16_t* out = dst + sx * factor;
      if (factor == 1) hn::StoreU(t, d, out);
      else if (factor == 2) hn::StoreInterleaved2(t, t, d, out);
      else hn::StoreInterleaved4(t, t, t, t, d, out);
    }
  }
#endif
  for (int x = sx * factor; x < out_width; ++x) {
    const int v = src[x / factor];
    dst[x] = v == kInvalid ? kInvalid : static_cast<std::int16_t>(std::clamp(v * factor, lo_q4, hi_q4));
  }
}

void Upscale(const Plane<std::int16_t>& src, int factor, int lo_q4, int hi_q4, Plane<std::int16_t>& dst) {
  const int w = dst.width(), h = dst.height();
  if (w == 0 || h == 0) return;
  const int src_rows = (h + factor - 1) / factor;
  parallel_lines(src_rows, [&](int sy0, int sy1) {
    for (int sy = sy0; sy < sy1; ++sy) {
      // The factor output rows of one source row are equal: compute the first, copy it.
      const int y0 = sy * factor, y_end = std::min(y0 + factor, h);
      UpscaleRow(src.row(sy), factor, lo_q4, hi_q4, w, dst.row(y0));
      for (int y = y0 + 1; y < y_end; ++y) std::memcpy(dst.row(y), dst.row(y0), sizeof(std::int16_t) * w);
    }
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(Upscale);
void upscale(const Plane<std::int16_t>& src, int factor, int lo_q4, int hi_q4, Plane<std::int16_t>& dst) {
  HWY_DYNAMIC_DISPATCH(Upscale)(src, factor, lo_q4, hi_q4, dst);
}
}  // namespace mctstereo::detail::cpu
#endif
