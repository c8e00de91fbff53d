// to_gray with Highway SIMD: RGB/BGR to BT.601 luma, (wR R + 150 G + wB B + 128) >> 8.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/gray.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cstring>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// One row of byte triplets (c0, c1, c2) in memory order: Y = (w0 c0 + 150 c1 + w2 c2 + 128) >> 8.
// The caller's rows carry no slack, so vectors only cover whole triplets inside the row and the
// last few pixels take the scalar formula.
void LumaRow(const std::uint8_t* HWY_RESTRICT src, int width, int w0, int w2,
             std::uint8_t* HWY_RESTRICT dst) {
  // Weights sum to 256, so the sum is at most 256 * 255 + 128 < 2^16: u16 lanes are exact.
  const hn::ScalableTag<std::uint16_t> d16;
  const hn::Rebind<std::uint8_t, decltype(d16)> d8;
  const hn::RebindToSigned<decltype(d16)> di16;
  const int n = static_cast<int>(hn::Lanes(d16));
  const auto k0 = hn::Set(d16, static_cast<std::uint16_t>(w0));
  const auto k1 = hn::Set(d16, 150);
  const auto k2 = hn::Set(d16, static_cast<std::uint16_t>(w2));
  const auto half = hn::Set(d16, 128);
  int x = 0;
  for (; x + n <= width; x += n) {
    hn::Vec<decltype(d8)> c0, c1, c2;
    hn::LoadInterleaved3(d8, src + 3 * x, c0, c1, c2);
    auto sum = hn::Add(hn::Mul(hn::PromoteTo(d16, c0), k0), half);
    sum = hn::Add(hn::Mul(hn::PromoteTo(d16, c1), k1), sum);
    sum = hn::Add(hn::Mul(hn::PromoteTo(d16, c2), k2), sum);
    // After the shift every lane is <= 255, so the signed view is exact and the demotion
    // does not saturate.
    const auto y = hn::BitCast(di16, hn::ShiftRight<8>(sum));
    hn::StoreU(hn::DemoteTo(d8, y), d8, dst + x);
  }
  for (; x < width; ++x)
    dst[x] = static_cast<std::uint8_t>((w0 * src[3 * x] + 150 * src[3 * x + 1] + w2 * src[3 * x + 2] + 128) >> 8);
}

void ToGray(const ImageView& src, Plane<std::uint8_t>& dst) {
  const int w = src.width, h = src.height;
  parallel_lines(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      switch (src.format) {
        case PixelFormat::Gray8:
          std::memcpy(dst.row(y), src.row(y), static_cast<std::size_t>(w));
          break;
        case PixelFormat::Rgb8:
          LumaRow(src.row(y), w, 77, 29, dst.row(y));
          break;
        case PixelFormat::Bgr8:
          LumaRow(src.row(y), w, 29, 77, dst.row(y));
          break;
      }
    }
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(ToGray);
void to_gray(const ImageView& src, Plane<std::uint8_t>& dst) { HWY_DYNAMIC_DISPATCH(ToGray)(src, dst); }
}  // namespace mctstereo::detail::cpu
#endif
