// Per-target helper of the bit-mask stages (fill, speckle): a vector compare as a 32-bit word.
// Included after <hwy/highway.h> by files that use foreach_target.h, so it is compiled once per
// SIMD target; the toggled guard is Highway's idiom for that.
#if defined(MCTSTEREO_CPU_MASK_BITS_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_MASK_BITS_INL_H_
#undef MCTSTEREO_CPU_MASK_BITS_INL_H_
#else
#define MCTSTEREO_CPU_MASK_BITS_INL_H_
#endif

#include <hwy/highway.h>

#include <cstdint>
#include <cstring>

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

// int16 lanes, at most 32 of them, so that one vector's mask fits one 32-bit word.
using MaskTag16 = hwy::HWY_NAMESPACE::CappedTag<std::int16_t, 32>;

// Bit i = lane i of the mask; bits past the vector's lanes are zero.
HWY_INLINE std::uint32_t MaskBits(hwy::HWY_NAMESPACE::Mask<MaskTag16> m) {
  const MaskTag16 d;
  std::uint8_t bytes[8] = {};
  hwy::HWY_NAMESPACE::StoreMaskBits(d, m, bytes);
  std::uint32_t bits;
  std::memcpy(&bits, bytes, sizeof(bits));
  const std::size_t n = hwy::HWY_NAMESPACE::Lanes(d);
  return n >= 32 ? bits : bits & ((1u << n) - 1);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
