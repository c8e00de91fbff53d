// The colour-weighted median with Highway SIMD: one vector of adjacent pixels of a row at a time
// (every lane shares the sample offsets, so each sample is one contiguous load per plane), OpenMP
// over rows.
//
// Per vector: the weight of each sample is lut[max over channels |C(p) - C(q)|] (0 for invalid
// samples), the colour distance taken in bytes, then looked up: 128 byte entries at once with
// AVX512-VBMI where the table ends below 128 (sigma <= 26), else 64 u16 entries at once on
// AVX-512 or 16 at a time with TableLookupBytes (only the blocks of the table that hold a
// non-zero entry: 4 of 16 with sigma 10). The weighted median is then found by a
// binary search over the whole disparities, per lane: with S(d) the weight of the samples whose
// whole disparity is <= d (monotone in d), the answer is the smallest d in [lo, hi] (the lane's
// smallest and largest sampled disparity) with S(d) >= ceil(total / 2); each pass halves every
// lane's interval with one compare and one masked add per sample, and the passes stop when every
// lane has converged (about log2 of the widest interval of the vector).
//
// Exact, as the reference: integer weights, sums of at most 961 x 64 < 2^16 in u16 lanes.
// Measured against a per-pixel histogram and a per-pixel sort (weighted_median_scalar, kept for
// bench/stage_benchmark.cpp): see docs/PIPELINE.md.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/weighted_median.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/vec_slot-inl.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>

#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using D16 = hn::ScalableTag<std::int16_t>;
using DU16 = hn::RebindToUnsigned<D16>;
#if HWY_TARGET != HWY_SCALAR
using DU8 = hn::Repartition<std::uint8_t, D16>;  // a whole vector of bytes (the table lookups)
#endif
using DC8 = hn::Rebind<std::uint8_t, D16>;       // one byte per lane (the colour loads)
using V16 = hn::Vec<D16>;
using VU16 = hn::Vec<DU16>;

constexpr int kMaxRows = 31;  // sample rows (or columns) at most: radius 15, step 1
constexpr int kMaxReach = 15;

// lut[k] for k in u16 lanes (k <= 255). The table is read 16 entries at a time: each block b
// covers k = 16 b .. 16 b + 15, and blocks past `blocks` hold only zeros.
#if HWY_TARGET == HWY_SCALAR
HWY_INLINE VU16 LookUp(const std::uint8_t* HWY_RESTRICT lut, int /*blocks*/, VU16 k) {
  return hn::Set(DU16(), lut[hn::GetLane(k)]);  // one lane
}
#else
HWY_INLINE VU16 LookUp(const std::uint8_t* HWY_RESTRICT lut, int blocks, VU16 k) {
  const DU16 du16;
  const DU8 du8;
  const auto lo = hn::BitCast(du8, hn::And(k, hn::Set(du16, 15)));  // bytes (k & 15, 0)
  const VU16 hi = hn::ShiftRight<4>(k);
  VU16 r = hn::Zero(du16);
  for (int b = 0; b < blocks; ++b) {
    const VU16 entry = hn::BitCast(du16, hn::TableLookupBytes(hn::LoadDup128(du8, lut + 16 * b), lo));
    r = hn::IfThenElse(hn::Eq(hi, hn::Set(du16, static_cast<std::uint16_t>(b))), entry, r);
  }
  // The high byte of each lane looked up entry 0.
  return hn::And(r, hn::Set(du16, 0xFF));
}
#endif

#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
// AVX-512BW: VPERMI2W looks up 64 u16 entries held in two registers, so the table (widened to
// u16) is four such pairs, of which only those with a non-zero entry are used; the pair of each
// lane is picked by k >> 6. Some 4 instructions per vector of 32 lanes where the 16-entry byte
// lookups above take 3 per block of 16 entries.
struct WideTable {
  __m512i part[8];  // entries 32 i .. 32 i + 31
  int pairs = 0;    // pairs of parts with a non-zero entry
};

HWY_INLINE WideTable MakeWideTable(const std::uint8_t* lut, int blocks) {
  WideTable t;
  HWY_ALIGN std::uint16_t wide[256];
  for (int k = 0; k < 256; ++k) wide[k] = lut[k];
  for (int i = 0; i < 8; ++i) t.part[i] = _mm512_load_si512(wide + 32 * i);
  t.pairs = (blocks * 16 + 63) / 64;
  return t;
}

HWY_INLINE VU16 LookUpWide(const WideTable& t, VU16 k) {
  __m512i r = _mm512_permutex2var_epi16(t.part[0], k.raw, t.part[1]);
  for (int p = 1; p < t.pairs; ++p) {
    const __m512i e = _mm512_permutex2var_epi16(t.part[2 * p], k.raw, t.part[2 * p + 1]);
    r = _mm512_mask_mov_epi16(r, _mm512_cmpge_epu16_mask(k.raw, _mm512_set1_epi16(static_cast<short>(64 * p))), e);
  }
  // Lanes past the used pairs (k >= 64 pairs) hold zeros in the table.
  r = _mm512_maskz_mov_epi16(_mm512_cmplt_epu16_mask(k.raw, _mm512_set1_epi16(static_cast<short>(64 * t.pairs))), r);
  return VU16{r};
}
#define MCTSTEREO_WM_WIDE_TABLE 1
#endif

#if HWY_TARGET == HWY_AVX3_DL
// AVX512-VBMI: VPERMI2B looks up 128 byte entries held in two registers, so wherever the table
// is zero from k = 128 on (sigma <= 26) the distances need not be widened first: one lookup of
// the 32 byte distances of a vector, and the widening to u16 zeroes the lanes with k >= 128 (the
// lookup reads their entry k - 128). Three instructions per vector where LookUpWide takes six
// and three widenings of the colours before it.
struct ByteTable {
  __m512i low, high;  // entries 0..63, 64..127
};

HWY_INLINE ByteTable MakeByteTable(const std::uint8_t* lut) {
  return {_mm512_loadu_si512(lut), _mm512_loadu_si512(lut + 64)};
}

HWY_INLINE VU16 LookUpBytes(const ByteTable& t, hn::Vec<DC8> k) {
  // The upper half of the index is undefined and so is the upper half of the result, unused.
  const __m256i entry = _mm512_castsi512_si256(_mm512_permutex2var_epi8(t.low, _mm512_castsi256_si512(k.raw), t.high));
  const __mmask32 below_128 = _mm256_testn_epi8_mask(k.raw, _mm256_set1_epi8(static_cast<char>(0x80)));
  return VU16{_mm512_maskz_cvtepu8_epi16(below_128, entry)};
}
#define MCTSTEREO_WM_BYTE_TABLE 1
#endif

// The weight tables of one frame, in the forms this target looks up.
struct WeightTables {
  const std::uint8_t* lut;
  int blocks;  // 16-entry blocks of lut up to its last non-zero entry
#ifdef MCTSTEREO_WM_WIDE_TABLE
  WideTable wide;
#endif
#ifdef MCTSTEREO_WM_BYTE_TABLE
  ByteTable bytes;
#endif
};

// lut[k] of the byte distances k; kBytes: the whole table lies in lut[0..127] (blocks <= 8).
template <bool kBytes>
HWY_INLINE VU16 Weight(const WeightTables& t, hn::Vec<DC8> k) {
#ifdef MCTSTEREO_WM_BYTE_TABLE
  if constexpr (kBytes) return LookUpBytes(t.bytes, k);
#endif
  const VU16 k16 = hn::PromoteTo(DU16(), k);
#ifdef MCTSTEREO_WM_WIDE_TABLE
  return LookUpWide(t.wide, k16);
#else
  return LookUp(t.lut, t.blocks, k16);
#endif
}

// The samples are kept as halves h = v >> 1 of their Q4 values: the whole disparity (v + 8) >> 4
// is then (h + 4) >> 3 without the overflow of v + 8, and it is monotone in h, so the lane's
// smallest and largest whole disparity are those of its smallest and largest h, and the search's
// test "whole disparity > mid" is h > 8 mid + 3 (both sides within int16 for |mid| <= 2048): one
// shift per sample where the whole disparity takes three.
HWY_INLINE V16 WholeOfHalf(V16 h) { return hn::ShiftRight<3>(hn::Add(h, hn::Set(D16(), 4))); }
HWY_INLINE V16 Whole(V16 v) { return WholeOfHalf(hn::ShiftRight<1>(v)); }

// One vector of output pixels. map[j], colour[c][j]: sample row j (of 2 K + 1), at the column of
// the vector's first pixel; offsets dx = -reach, -reach + step, ..., reach are read from there.
template <int kChannels, bool kByteTable>
HWY_INLINE V16 MedianVector(const std::int16_t* const* map, const std::uint8_t* const (*colour)[kMaxRows], int rows,
                            int reach, int step, const WeightTables& tables, std::int16_t* HWY_RESTRICT disp,
                            std::uint16_t* HWY_RESTRICT weight) {
  const D16 d;
  const DU16 du16;
  const DC8 dc8;
  const std::size_t n = hn::Lanes(d);
  const int centre = rows / 2;
  const V16 invalid = hn::Set(d, kInvalid);
  // The colour distance max |C(p) - C(q)| <= 255 is taken in bytes and widened once (or not at
  // all: LookUpBytes).
  VecSlot<DC8> centre_colour[kChannels];
  for (int c = 0; c < kChannels; ++c) centre_colour[c] = hn::LoadU(dc8, colour[c][centre]);

  // Weights and whole disparities of the samples; the lane's range and total.
  V16 lo = hn::Set(d, 32767), hi = hn::Set(d, -32768);
  VU16 total = hn::Zero(du16);
  int s = 0;
  for (int j = 0; j < rows; ++j) {
    for (int dx = -reach; dx <= reach; dx += step, ++s) {
      const V16 v = hn::LoadU(d, map[j] + dx);
      const auto distance = [&](int c) {
        const auto q = hn::LoadU(dc8, colour[c][j] + dx);
        return hn::Or(hn::SaturatedSub(q, centre_colour[c]), hn::SaturatedSub(centre_colour[c], q));
      };
      auto k = distance(0);
      for (int c = 1; c < kChannels; ++c) k = hn::Max(k, distance(c));
      const VU16 looked_up = Weight<kByteTable>(tables, k);
      const VU16 w = hn::IfThenZeroElse(hn::RebindMask(du16, hn::Eq(v, invalid)), looked_up);
      const V16 half_v = hn::ShiftRight<1>(v);
      const auto counts = hn::RebindMask(d, hn::Gt(hn::BitCast(d, w), hn::Zero(d)));  // w <= 64
      lo = hn::IfThenElse(counts, hn::Min(lo, half_v), lo);
      hi = hn::IfThenElse(counts, hn::Max(hi, half_v), hi);
      total = hn::Add(total, w);
      hn::Store(half_v, d, disp + s * n);
      hn::Store(w, du16, weight + s * n);
    }
  }
  const int samples = s;
  const V16 own = hn::LoadU(d, map[centre]);
  const auto empty = hn::RebindMask(d, hn::Eq(total, hn::Zero(du16)));
  // Lanes without weight: an empty interval that never moves (their output is the pixel itself).
  lo = hn::IfThenZeroElse(empty, WholeOfHalf(lo));
  hi = hn::IfThenZeroElse(empty, WholeOfHalf(hi));
  const VU16 half = hn::ShiftRight<1>(hn::Add(total, hn::Set(du16, 1)));  // ceil(total / 2)

  // Invariant: the answer lies in [lo, hi] (S(hi) >= half).
  while (!hn::AllTrue(d, hn::Eq(lo, hi))) {
    const V16 mid = hn::ShiftRight<1>(hn::Add(lo, hi));  // floor; |lo|, |hi| <= 2048
    const V16 threshold = hn::Add(hn::ShiftLeft<3>(mid), hn::Set(d, 3));  // whole > mid: h > 8 mid + 3
    VU16 sum = hn::Zero(du16);
    for (int i = 0; i < samples; ++i) {
      const auto above = hn::RebindMask(du16, hn::Gt(hn::Load(d, disp + i * n), threshold));
      sum = hn::Add(sum, hn::IfThenZeroElse(above, hn::Load(du16, weight + i * n)));
    }
    // sum >= half, as saturating half - sum == 0 (u16 lanes hold sums beyond the i16 range).
    const auto enough = hn::RebindMask(d, hn::Eq(hn::SaturatedSub(half, sum), hn::Zero(du16)));
    hi = hn::IfThenElse(enough, mid, hi);
    lo = hn::IfThenElse(enough, lo, hn::Add(mid, hn::Set(d, 1)));
  }
  const auto keeps = hn::Or(empty, hn::AndNot(hn::Eq(own, invalid), hn::Eq(Whole(own), lo)));
  return hn::IfThenElse(keeps, own, hn::ShiftLeft<4>(lo));
}

template <int kChannels, bool kByteTable>
void MedianRows(const Plane<std::int16_t>& src, const ColourPlanes& colour, const WeightedMedianConfig& config,
                const WeightTables& tables, Plane<std::int16_t>& dst) {
  const D16 d;
  const int w = src.width(), h = src.height();
  const int n = static_cast<int>(hn::Lanes(d));
  constexpr std::size_t kMaxLanes = hn::MaxLanes(D16());
  const int step = config.step, reach = config.radius / step * step;
  const int rows = 2 * (reach / step) + 1;

  parallel_for(h, 4, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      HWY_ALIGN std::int16_t disp[kMaxWeightedMedianSamples * kMaxLanes];
      HWY_ALIGN std::uint16_t weight[kMaxWeightedMedianSamples * kMaxLanes];
      // Vectors near a border (or every vector of a narrow map) read copies of their window with
      // clamped columns: kMaxLanes + 2 reach entries, and a vector's slack after them.
      constexpr int kBorderWidth = kMaxLanes + 2 * kMaxReach + kMaxLanes;
      HWY_ALIGN std::int16_t border_map[kMaxRows][kBorderWidth];
      HWY_ALIGN std::uint8_t border_colour[3][kMaxRows][kBorderWidth];
      HWY_ALIGN std::int16_t tail[kMaxLanes];
      const std::int16_t* map_rows[kMaxRows];
      const std::uint8_t* colour_rows[3][kMaxRows];
      for (int j = 0; j < rows; ++j) {
        const int yj = clamp_index(y + (j - rows / 2) * step, h);
        map_rows[j] = src.row(yj);
        for (int c = 0; c < kChannels; ++c) colour_rows[c][j] = colour.plane[c]->row(yj);
      }
      std::int16_t* out = dst.row(y);
      for (int x0 = 0; x0 < w; x0 += n) {
        const std::int16_t* map[kMaxRows];
        const std::uint8_t* col[3][kMaxRows];
        if (x0 >= reach && x0 + n + reach <= w) {
          for (int j = 0; j < rows; ++j) {
            map[j] = map_rows[j] + x0;
            for (int c = 0; c < kChannels; ++c) col[c][j] = colour_rows[c][j] + x0;
          }
        } else {
          for (int j = 0; j < rows; ++j) {
            copy_clamped(map_rows[j], w, x0 - reach, n + 2 * reach, border_map[j]);
            for (int c = 0; c < kChannels; ++c)
              copy_clamped(colour_rows[c][j], w, x0 - reach, n + 2 * reach, border_colour[c][j]);
            map[j] = border_map[j] + reach;
            for (int c = 0; c < kChannels; ++c) col[c][j] = border_colour[c][j] + reach;
          }
        }
        const V16 m = MedianVector<kChannels, kByteTable>(map, col, rows, reach, step, tables, disp, weight);
        if (x0 + n <= w) {
          hn::StoreU(m, d, out + x0);
        } else {
          hn::Store(m, d, tail);
          std::memcpy(out + x0, tail, sizeof(std::int16_t) * (w - x0));
        }
      }
    }
  });
}

void WeightedMedian(const Plane<std::int16_t>& src, const ColourPlanes& colour, const WeightedMedianConfig& config,
                    Plane<std::int16_t>& dst) {
  WeightTables tables;
  tables.lut = config.lut.data();
  tables.blocks = 0;
  for (int k = 0; k < 256; ++k)
    if (config.lut[k] != 0) tables.blocks = k / 16 + 1;
#ifdef MCTSTEREO_WM_WIDE_TABLE
  tables.wide = MakeWideTable(tables.lut, tables.blocks);
#endif
#ifdef MCTSTEREO_WM_BYTE_TABLE
  tables.bytes = MakeByteTable(tables.lut);
  if (tables.blocks <= 8) {
    if (colour.channels == 3) MedianRows<3, true>(src, colour, config, tables, dst);
    else MedianRows<1, true>(src, colour, config, tables, dst);
    return;
  }
#endif
  if (colour.channels == 3) MedianRows<3, false>(src, colour, config, tables, dst);
  else MedianRows<1, false>(src, colour, config, tables, dst);
}

#undef MCTSTEREO_WM_WIDE_TABLE
#undef MCTSTEREO_WM_BYTE_TABLE
}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(WeightedMedian);

void weighted_median(const Plane<std::int16_t>& src, const ColourPlanes& colour, const WeightedMedianConfig& config,
                     Plane<std::int16_t>& dst) {
  if (src.width() == 0 || src.height() == 0) return;
  HWY_DYNAMIC_DISPATCH(WeightedMedian)(src, colour, config, dst);
}

// The scalar forms, for measurement: the samples of a pixel as (d, w), then a histogram over
// [smallest d, largest d] or a sort, and the same scan for ceil(total / 2).
void weighted_median_scalar(const Plane<std::int16_t>& src, const ColourPlanes& colour,
                            const WeightedMedianConfig& config, WeightedMedianMethod method,
                            Plane<std::int16_t>& dst) {
  const int w = src.width(), h = src.height();
  const int step = config.step, reach = config.radius / step * step;
  const int channels = colour.channels;
  parallel_for(h, 4, [&](int y0, int y1) {
    for (int y = y0; y < y1; ++y) {
      std::pair<int, int> samples[kMaxWeightedMedianSamples];
      int histogram[4097] = {};  // whole disparities -2048 .. 2048
      const std::uint8_t* centre[3];
      for (int c = 0; c < channels; ++c) centre[c] = colour.plane[c]->row(y);
      for (int x = 0; x < w; ++x) {
        int count = 0, total = 0, lo = 1 << 20, hi = -(1 << 20);
        for (int dy = -reach; dy <= reach; dy += step) {
          const int qy = clamp_index(y + dy, h);
          const std::int16_t* row = src.row(qy);
          for (int dx = -reach; dx <= reach; dx += step) {
            const int qx = clamp_index(x + dx, w);
            const int v = row[qx];
            if (v == kInvalid) continue;
            int k = 0;
            for (int c = 0; c < channels; ++c) {
              const int diff = centre[c][x] - colour.plane[c]->row(qy)[qx];
              k = std::max(k, diff < 0 ? -diff : diff);
            }
            const int weight = config.lut[k];
            if (weight == 0) continue;
            const int dv = q4_to_whole(v);
            samples[count++] = {dv, weight};
            total += weight;
            lo = std::min(lo, dv);
            hi = std::max(hi, dv);
          }
        }
        const int own = src.row(y)[x];
        if (total == 0) {
          dst.row(y)[x] = static_cast<std::int16_t>(own);
          continue;
        }
        const int half = (total + 1) / 2;
        int median = hi;
        if (method == WeightedMedianMethod::Histogram) {
          for (int i = 0; i < count; ++i) histogram[samples[i].first + 2048] += samples[i].second;
          int running = 0;
          for (int dv = lo; dv <= hi; ++dv) {
            running += histogram[dv + 2048];
            if (running >= half) {
              median = dv;
              break;
            }
          }
          for (int i = 0; i < count; ++i) histogram[samples[i].first + 2048] = 0;
        } else {
          std::sort(samples, samples + count);
          int running = 0;
          for (int i = 0; i < count; ++i) {
            running += samples[i].second;
            if (running >= half) {
              median = samples[i].first;
              break;
            }
          }
        }
        dst.row(y)[x] = own != kInvalid && q4_to_whole(own) == median ? static_cast<std::int16_t>(own)
                                                                      : static_cast<std::int16_t>(16 * median);
      }
    }
  });
}

}  // namespace mctstereo::detail::cpu
#endif
