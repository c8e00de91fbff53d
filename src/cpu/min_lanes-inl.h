// Per-target helpers of the band SGM stages: the smallest u16 lane of a vector (and the first lane
// holding it). Highway's MinOfLanes builds a u16 minimum out of 32-bit halves and shuffles (some
// 12 instructions on x86); SSE4.1's PHMINPOSUW finds the minimum of 8 u16 lanes and its first
// index in one, and the path recursion needs such a minimum at every step of every path.
// Included after <hwy/highway.h> by files that use foreach_target.h (Highway's toggled guard).
#if defined(MCTSTEREO_CPU_MIN_LANES_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_MIN_LANES_INL_H_
#undef MCTSTEREO_CPU_MIN_LANES_INL_H_
#else
#define MCTSTEREO_CPU_MIN_LANES_INL_H_
#endif

#include <hwy/highway.h>

#include <cstdint>

#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
#include <immintrin.h>
#endif

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

// Vectors of at most 16 u16 lanes.
using MinTagU16 = hwy::HWY_NAMESPACE::CappedTag<std::uint16_t, 16>;
using MinVecU16 = hwy::HWY_NAMESPACE::Vec<MinTagU16>;
// The wide tag of the SGM stages: slots of 32 entries and more take vectors of up to 32 lanes,
// one AVX-512 (or 512-bit SVE) vector per 32 candidates, half the instructions of two 16-lane
// vectors for the same values.
using WideTagU16 = hwy::HWY_NAMESPACE::CappedTag<std::uint16_t, 32>;

/// Whether slots of `stride` entries go by WideTagU16: the target has more lanes there than in
/// MinTagU16, and the stride is a multiple of them.
HWY_INLINE bool WideSlots(int stride) {
  const int wide = static_cast<int>(hwy::HWY_NAMESPACE::Lanes(WideTagU16()));
  return wide > static_cast<int>(hwy::HWY_NAMESPACE::Lanes(MinTagU16())) && stride % wide == 0;
}

#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
// PHMINPOSUW of 8 lanes: bits 0..15 the minimum, bits 16..18 its first index.
HWY_INLINE std::uint32_t MinPos8(__m128i v) { return static_cast<std::uint32_t>(_mm_cvtsi128_si32(_mm_minpos_epu16(v))); }
#endif

/// The smallest lane of v (a template, so that only the branch of v's width is compiled).
template <class V = MinVecU16>
HWY_INLINE int MinLane(V v) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
  if constexpr (sizeof(v.raw) == 64) {
    namespace hn = hwy::HWY_NAMESPACE;
    const hn::Half<hn::DFromV<V>> half;
    return MinLane(hn::Min(hn::LowerHalf(half, v), hn::UpperHalf(half, v)));
  } else if constexpr (sizeof(v.raw) == 32) {
    return MinPos8(_mm_min_epu16(_mm256_castsi256_si128(v.raw), _mm256_extracti128_si256(v.raw, 1))) & 0xFFFF;
  } else {
    return MinPos8(v.raw) & 0xFFFF;
  }
#else
  return hwy::HWY_NAMESPACE::GetLane(hwy::HWY_NAMESPACE::MinOfLanes(MinTagU16(), v));
#endif
}

/// The smallest of the lanes of d in v (d of up to 32 u16 lanes).
template <class D, class V>
HWY_INLINE int MinLaneOf(D d, V v) {
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
  (void)d;
  return MinLane(v);
#else
  return hwy::HWY_NAMESPACE::GetLane(hwy::HWY_NAMESPACE::MinOfLanes(d, v));
#endif
}

/// The smallest of the lanes of d in v; `index` = the first lane that holds it.
template <class D, class V>
HWY_INLINE int FirstMinLane(D d, V v, int& index) {
  namespace hn = hwy::HWY_NAMESPACE;
#if HWY_ARCH_X86 && HWY_TARGET <= HWY_SSE4
  (void)d;
  if constexpr (sizeof(v.raw) == 64) {
    const hn::DFromV<V> full;  // d may be a tag of the same lanes; the raw width decides here
    const int m = MinLane(v);
    index = static_cast<int>(hn::FindFirstTrue(full, hn::Eq(v, hn::Set(full, static_cast<std::uint16_t>(m)))));
    return m;
  } else if constexpr (sizeof(v.raw) == 32) {
    const std::uint32_t lo = MinPos8(_mm256_castsi256_si128(v.raw));
    const std::uint32_t hi = MinPos8(_mm256_extracti128_si256(v.raw, 1));
    // Ties go to the lower half: its lanes come first.
    const bool low = (lo & 0xFFFF) <= (hi & 0xFFFF);
    index = low ? static_cast<int>(lo >> 16) : 8 + static_cast<int>(hi >> 16);
    return static_cast<int>((low ? lo : hi) & 0xFFFF);
  } else {
    const std::uint32_t r = MinPos8(v.raw);
    index = static_cast<int>(r >> 16);
    return static_cast<int>(r & 0xFFFF);
  }
#else
  const auto m = hn::MinOfLanes(d, v);
  index = static_cast<int>(hn::FindFirstTrue(d, hn::Eq(v, m)));
  return hn::GetLane(m);
#endif
}

/// The smallest and the largest int16 lane of v (d of up to 32 lanes): MinLaneOf on u16 forms
/// that keep the order (v ^ 0x8000) or reverse it (v ^ 0x7FFF). On x86 some 6 instructions where
/// Highway's int16 MinOfLanes takes some 16.
template <class D, class V>
HWY_INLINE int MinLaneI16(D d, V v) {
  namespace hn = hwy::HWY_NAMESPACE;
  const hn::RebindToUnsigned<D> du;
  return static_cast<std::int16_t>(MinLaneOf(du, hn::BitCast(du, hn::Xor(v, hn::Set(d, INT16_MIN)))) ^ 0x8000);
}
template <class D, class V>
HWY_INLINE int MaxLaneI16(D d, V v) {
  namespace hn = hwy::HWY_NAMESPACE;
  const hn::RebindToUnsigned<D> du;
  return static_cast<std::int16_t>(MinLaneOf(du, hn::BitCast(du, hn::Xor(v, hn::Set(d, INT16_MAX)))) ^ 0x7FFF);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
