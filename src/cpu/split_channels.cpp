// split_channels with Highway SIMD: interleaved byte triplets into three planes.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/split_channels.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <cstring>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// The caller's rows carry no slack: vectors cover whole triplets inside the row, the last few
// pixels go one by one.
void SplitRow(const std::uint8_t* HWY_RESTRICT src, int width, std::uint8_t* HWY_RESTRICT c0,
              std::uint8_t* HWY_RESTRICT c1, std::uint8_t* HWY_RESTRICT c2) {
  const hn::ScalableTag<std::uint8_t> d8;
  const int n = static_cast<int>(hn::Lanes(d8));
  int x = 0;
  for (; x + n <= width; x += n) {
    hn::Vec<decltype(d8)> a, b, c;
    hn::LoadInterleaved3(d8, src + 3 * x, a, b, c);
    hn::StoreU(a, d8, c0 + x);
    hn::StoreU(b, d8, c1 + x);
    hn::StoreU(c, d8, c2 + x);
  }
  for (; x < width; ++x) {
    c0[x] = src[3 * x];
    c1[x] = src[3 * x + 1];
    c2[x] = src[3 * x + 2];
  }
}

void SplitChannels(const ImageView& src, std::array<Plane<std::uint8_t>, 3>& dst) {
  const int w = src.width, h = src.height;
  parallel_lines(h, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      if (src.format == PixelFormat::Gray8) std::memcpy(dst[0].row(y), src.row(y), static_cast<std::size_t>(w));
      else SplitRow(src.row(y), w, dst[0].row(y), dst[1].row(y), dst[2].row(y));
    }
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(SplitChannels);
void split_channels(const ImageView& src, std::array<Plane<std::uint8_t>, 3>& dst) {
  HWY_DYNAMIC_DISPATCH(SplitChannels)(src, dst);
}
}  // namespace mctstereo::detail::cpu
#endif
