// Fills runs of invalid pixels along a row from the run's two valid neighbours, per SIMD target
// (fill.cpp and the finest level's refinement in strips, refine_left_map.cpp, share it).
//
// Disparity maps hold many short invalid runs (often single pixels), so a pixel-by-pixel scan is
// dominated by mispredicted branches. Instead, SIMD compares turn 32 pixels at a time into a bit
// mask of invalid pixels; the starts and ends of runs are bit transitions of that mask, visited
// with bit scans, and runs of up to one short vector are written with one blended store.
// Included after <hwy/highway.h> by files that use foreach_target.h; the toggled guard is
// Highway's idiom for that.
#if defined(MCTSTEREO_CPU_FILL_ROW_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_FILL_ROW_INL_H_
#undef MCTSTEREO_CPU_FILL_ROW_INL_H_
#else
#define MCTSTEREO_CPU_FILL_ROW_INL_H_
#endif

#include <hwy/highway.h>

#include "cpu/mask_bits-inl.h"

#include <algorithm>
#include <bit>
#include <cstdint>

#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using FillShortTag = hn::CappedTag<std::int16_t, 8>;  // writes the short runs

// Fills the invalid run [s, e) of a row w wide.
HWY_INLINE void FillRun(std::int16_t* row, int s, int e, int w, FillMode mode) {
  if (s == 0 && e == w) return;  // no valid pixel in the row
  if (s == 0 || e == w) {
    std::fill(row + s, row + e, s == 0 ? row[e] : row[s - 1]);
    return;
  }
  const std::int16_t left = row[s - 1], right = row[e];
  const std::int16_t lower = std::min(left, right);
  // Pixel s + t is 1 + t from the left neighbour and len - t from the right one: the first
  // len / 2 are closer to the left, the last len / 2 to the right, and an odd run has one pixel
  // in the middle at equal distance, which takes the smaller value.
  const int len = e - s, half = mode == FillMode::NearestLower ? 0 : len / 2;
  const FillShortTag ds;
  if (len <= static_cast<int>(hn::Lanes(ds))) {
    // Lanes past the run rewrite the values they hold (the row's slack at the end of a row).
    const auto t = hn::Iota(ds, 0);
    const auto v = hn::IfThenElse(hn::Lt(t, hn::Set(ds, half)), hn::Set(ds, left),
                                  hn::IfThenElse(hn::Lt(t, hn::Set(ds, len - half)), hn::Set(ds, lower),
                                                 hn::Set(ds, right)));
    hn::StoreU(hn::IfThenElse(hn::FirstN(ds, len), v, hn::LoadU(ds, row + s)), ds, row + s);
    return;
  }
  std::fill(row + s, row + s + half, left);
  std::fill(row + s + half, row + e - half, lower);
  std::fill(row + e - half, row + e, right);
}

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
// NearestLower by vector scans (AVX-512). Every invalid pixel takes min(L, R) of the nearest valid
// values to its left and right, or the one that exists, or stays invalid where the row has none:
// FillRun's rule, which gives each run min(left, right), or its one neighbour at a row end. L
// comes from a forward scan, R from a backward one, both 32 lanes at a time: in log steps of 1, 2,
// 4, 8 and 16 lanes each lane that is still invalid takes the lane s lanes away (VPERMT2W), so
// that a lane ends with the nearest value within the vector, else the one carried in from the
// vector before. min(L, R) is taken on v + 32767 as unsigned, which keeps the order of the valid
// values and puts kInvalid (no value) last. Measured on the LR-checked maps of realtime at
// 640 x 480 (18 % invalid, in many short runs): the fill took 0.12 ms instead of 0.19 (1 thread).
constexpr int kFillBlock = 1024;  // columns whose backward values are kept at once (2 KiB)

struct FillSlides {
  // Lane i takes lane i - s (up, from the left) or i + s (down, from the right); 32 names the
  // second table, kInvalid.
  alignas(64) std::int16_t up[5][32], down[5][32];
  constexpr FillSlides() : up(), down() {
    for (int k = 0; k < 5; ++k)
      for (int i = 0; i < 32; ++i) {
        const int s = 1 << k;
        up[k][i] = static_cast<std::int16_t>(i >= s ? i - s : 32);
        down[k][i] = static_cast<std::int16_t>(i + s < 32 ? i + s : 32);
      }
  }
};
inline constexpr FillSlides kFillSlides{};

// After the steps of 1, 2, 4, 8 and 16 lanes, a lane holds the nearest valid value among the 32
// lanes on its side (itself included); lanes with none there take the carried value.
HWY_INLINE __m512i FillPropagate(__m512i val, __m512i carry, const std::int16_t (*slides)[32]) {
  const __m512i invalid = _mm512_set1_epi16(kInvalid);
  for (int k = 0; k < 5; ++k) {
    const __m512i moved = _mm512_permutex2var_epi16(val, _mm512_load_si512(slides[k]), invalid);
    val = _mm512_mask_blend_epi16(_mm512_cmpeq_epi16_mask(val, invalid), val, moved);
  }
  return _mm512_mask_blend_epi16(_mm512_cmpeq_epi16_mask(val, invalid), val, carry);
}

HWY_INLINE __mmask32 FillLanes(int n) { return n >= 32 ? 0xFFFFFFFFu : (1u << n) - 1u; }

HWY_INLINE void FillRowLowerScans(std::int16_t* row, int w) {
  const __m512i invalid = _mm512_set1_epi16(kInvalid), bias = _mm512_set1_epi16(32767);
  alignas(64) std::int16_t right[kFillBlock];  // R of the block's columns (vectors with an invalid pixel)
  __m512i left_carry = invalid;
  for (int b0 = 0; b0 < w; b0 += kFillBlock) {
    const int b1 = std::min(w, b0 + kFillBlock);
    __m512i right_carry = invalid;  // the first valid value at or after b1
    for (int x = b1; x < w; x += 32) {
      const __mmask32 valid = _mm512_mask_cmpneq_epi16_mask(FillLanes(w - x), _mm512_loadu_si512(row + x), invalid);
      if (valid != 0) {
        right_carry = _mm512_set1_epi16(row[x + std::countr_zero(valid)]);
        break;
      }
    }
    const int last = b0 + (b1 - b0 - 1) / 32 * 32;
    for (int x = last; x >= b0; x -= 32) {
      const __mmask32 lanes = FillLanes(b1 - x);
      const __m512i v = _mm512_loadu_si512(row + x);
      const __mmask32 bad = _mm512_mask_cmpeq_epi16_mask(lanes, v, invalid);
      if (bad == 0) {
        right_carry = _mm512_set1_epi16(row[x]);
        continue;
      }
      // Lanes past the block count as invalid: the carry stands for them.
      const __m512i val = FillPropagate(_mm512_mask_blend_epi16(~lanes, v, invalid), right_carry, kFillSlides.down);
      _mm512_store_si512(right + (x - b0), val);
      right_carry = _mm512_permutexvar_epi16(_mm512_setzero_si512(), val);
    }
    for (int x = b0; x < b1; x += 32) {
      const __mmask32 lanes = FillLanes(b1 - x);
      const int last_lane = std::min(31, b1 - 1 - x);
      const __m512i v = _mm512_loadu_si512(row + x);
      const __mmask32 bad = _mm512_mask_cmpeq_epi16_mask(lanes, v, invalid);
      if (bad == 0) {
        left_carry = _mm512_set1_epi16(row[x + last_lane]);
        continue;
      }
      const __m512i val = FillPropagate(_mm512_mask_blend_epi16(~lanes, v, invalid), left_carry, kFillSlides.up);
      left_carry = _mm512_permutexvar_epi16(_mm512_set1_epi16(static_cast<std::int16_t>(last_lane)), val);
      const __m512i lower = _mm512_min_epu16(_mm512_add_epi16(val, bias),
                                             _mm512_add_epi16(_mm512_load_si512(right + (x - b0)), bias));
      _mm512_mask_storeu_epi16(row + x, bad, _mm512_sub_epi16(lower, bias));
    }
  }
}
#endif

// Fills the invalid runs of one row w wide (with the planes' 64 bytes of slack after w).
HWY_INLINE void FillRow(std::int16_t* row, int w, FillMode mode) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  if (mode == FillMode::NearestLower) {
    FillRowLowerScans(row, w);
    return;
  }
#endif
  const MaskTag16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const auto invalid = hn::Set(d, kInvalid);
  int start = 0;            // first pixel of the open run
  std::uint32_t carry = 0;  // whether the pixel before the current word is invalid
  for (int x0 = 0; x0 < w; x0 += 32) {
    std::uint32_t bad = 0;
    for (int x = x0; x < std::min(x0 + 32, w); x += n) bad |= MaskBits(hn::Eq(hn::LoadU(d, row + x), invalid)) << (x - x0);
    // Bits at and past w (the slack) count as valid pixels that end no run.
    const std::uint32_t in_row = w - x0 >= 32 ? ~0u : (1u << (w - x0)) - 1;
    bad &= in_row;
    const std::uint32_t bad_before = (bad << 1) | carry;  // bit i: pixel x0 + i - 1 is invalid
    carry = bad >> 31;
    const std::uint32_t starts = bad & ~bad_before;
    const std::uint32_t ends = ~bad & bad_before & in_row;
    // Starts and ends alternate, so each end closes the run of the start before it.
    for (std::uint32_t events = starts | ends; events != 0; events &= events - 1) {
      const int b = std::countr_zero(events);
      if ((starts >> b) & 1u) start = x0 + b;
      else FillRun(row, start, x0 + b, w, mode);
    }
  }
  if (row[w - 1] == kInvalid) FillRun(row, start, w, w, mode);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
