// Band SGM costs with Highway SIMD over a pixel's candidates, OpenMP over rows.
//
// The cost of candidate lo + k of pixel x is a sum over the a x a window of
// popcount(left(x + i, y + j) XOR right(x + i - lo - k, y + j)): along k the right view's codes run
// backwards. The right view's codes are therefore first mirrored (m(t) = right(W - 1 - t), with
// clamped columns in the padding), so that the codes of candidates k = 0, 1, ... lie at the
// increasing addresses t = W - 1 - x - i + lo + k and one unaligned load brings a vector of them.
// Mirrored planes carry stride + 16 padding columns: a valid candidate reads t in [-h, W + h), and
// the lanes past a pixel's count (masked to kSgmInf) at most a slot further, or, in a run of pixels
// that share lo (RowCosts), a slot and kMaxRun - 1 entries further.
//
// The band of a pixel depends on its coarse pixel (x/2, y/2) and then on x through the clip to
// the image: the prior's minima and maxima over the prior_size x prior_size neighbourhood are
// computed once per coarse pixel of a row with running column extrema, as sgm_band_at() does per
// pixel.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/sgm_costs.cpp"
#ifndef HWY_WANT_AVX3_DL
#define HWY_WANT_AVX3_DL
#endif
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <omp.h>

#include <algorithm>
#include <limits>

#include "cpu/parallel.hpp"
#include "cpu/search_range-inl.h"
#include "cpu/sgm_segments.hpp"
#include "stages.hpp"

#ifndef MCTSTEREO_CPU_SGM_COSTS_ONCE
#define MCTSTEREO_CPU_SGM_COSTS_ONCE
namespace mctstereo::detail::cpu {

// The band of every coarse pixel of coarse row cy before the clip to the image: [lo, hi] and the
// centre c (sgm_band_at()'s terms), in lo_c, hi_c, centre_c (cw entries each); with the temporal
// prior (narrow_lo_c not null) also the band of the temporal radius, in narrow_lo_c, narrow_hi_c.
inline void coarse_bands(const Plane<std::int16_t>& coarse, const SgmBandConfig& config, int cy, int* lo_c, int* hi_c,
                         int* centre_c, int* col_min, int* col_max, int* narrow_lo_c, int* narrow_hi_c) {
  const int cw = coarse.width(), ch = coarse.height(), h = config.prior_size / 2;
  constexpr int kNone = 1 << 20;
  for (int cx = 0; cx < cw; ++cx) {
    int mn = kNone, mx = -kNone;
    for (int j = -h; j <= h; ++j) {
      const int v = coarse.at(cx, clamp_index(cy + j, ch));
      if (v == kInvalid) continue;
      mn = std::min(mn, v >> 4);
      mx = std::max(mx, v >> 4);
    }
    col_min[cx] = mn;
    col_max[cx] = mx;
  }
  for (int cx = 0; cx < cw; ++cx) {
    const int centre = coarse.at(cx, cy);
    if (centre == kInvalid) {
      lo_c[cx] = config.dmin;
      hi_c[cx] = config.dmax;
      centre_c[cx] = (config.dmin + config.dmax) >> 1;
      if (narrow_lo_c != nullptr) narrow_lo_c[cx] = config.dmin, narrow_hi_c[cx] = config.dmax;
      continue;
    }
    int mn = kNone, mx = -kNone;
    for (int i = -h; i <= h; ++i) {
      const int c = clamp_index(cx + i, cw);
      mn = std::min(mn, col_min[c]);
      mx = std::max(mx, col_max[c]);
    }
    lo_c[cx] = std::min(std::max(config.dmin, 2 * mn - config.radius), config.dmax);
    hi_c[cx] = std::max(std::min(config.dmax, 2 * mx + config.radius), config.dmin);
    centre_c[cx] = 2 * (centre >> 4);
    if (narrow_lo_c != nullptr) {
      narrow_lo_c[cx] = std::min(std::max(config.dmin, 2 * mn - config.temporal.radius), config.dmax);
      narrow_hi_c[cx] = std::max(std::min(config.dmax, 2 * mx + config.temporal.radius), config.dmin);
    }
  }
}

}  // namespace mctstereo::detail::cpu
#endif

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DU32 = hn::CappedTag<std::uint32_t, 16>;
using DI32 = hn::RebindToSigned<DU32>;

// Mirrors rows [r0, r1) of the right view's codes into the mirrored planes (from their row
// v.mirror_row0).
void MirrorCodes(const CensusCodes& right, int r0, int r1, SgmVolume& v) {
  const int w = v.width;
  parallel_lines(r1 - r0, [&](int i0, int i1) {
    for (int y = r0 + i0; y < r0 + i1; ++y) {
      for (int k = 0; k < right.words; ++k) {
        const std::uint32_t* src = right.plane[k].row(y);
        std::uint32_t* dst = v.mirrored[k].row(y - v.mirror_row0);
        const int pad = v.mirrored[k].pad();
        for (int t = -pad; t < w + pad; ++t) dst[t] = src[clamp_index(w - 1 - t, w)];
      }
    }
  });
}

// Pixels of a row that share their band's lower end (the fine pixels of one coarse pixel, or of
// a smooth prior: 7.1 on average in quality at 640 x 480) go together, at most this many. A run
// reads the mirrored codes up to its widest count, at most kMaxRun - 1 entries past where a lone
// pixel's reads end, which stays inside the planes' padding (mirror_pad(): the slot plus 16).
constexpr int kMaxRun = 8;

// Costs of the candidates k = 0 .. stride - 1 of every pixel of a row (those past count are
// kSgmInf), the window's rows of codes given by pointers. One call per row, so that the window's
// loops unroll (kWords, kA) and its row pointers stay in registers.
// T: the volume's cost entries, u16 or (where every cost is below kSgmInf8) bytes; kSgmInf
// saturates to either's largest value.
//
// The box sum is separable where pixels share lo: the cost of candidate lo + k of pixel x is the
// sum over the window's columns c = x - h .. x + h of H(c, k), the Hamming distances of column c
// summed over the window's rows, and H(c, k) depends on c and lo + k only. A run of r such pixels
// makes r + a - 1 column vectors of H and adds a of them per pixel, where pixel by pixel it would
// make a x r: with a 3x3 window, 2.3 times fewer popcounts at runs of 7 (the stage 30 % shorter in a
// profile of quality at 640 x 480, 1 thread).
template <int kWords, int kA, class T>
void RowCosts(const std::uint32_t* const* left_rows, const std::uint32_t* const* mirror_rows, int w,
              const std::int16_t* lo_row, const std::int16_t* count_row, int stride, T* HWY_RESTRICT out) {
  constexpr int kH = kA / 2;
  constexpr T kInf = std::numeric_limits<T>::max();  // kSgmInf or kSgmInf8
  const DU32 du32;
  const DI32 di32;
  const hn::Rebind<T, DI32> dout;
  const int n = static_cast<int>(hn::Lanes(du32));
  const std::uint32_t* left[kA * kWords];
  const std::uint32_t* mirror[kA * kWords];
  for (int j = 0; j < kA; ++j)
    for (int word = 0; word < kWords; ++word) {
      left[j * kWords + word] = left_rows[j * 3 + word];
      mirror[j * kWords + word] = mirror_rows[j * 3 + word];
    }
  const auto inf = hn::Set(di32, kSgmInf);
  const auto inf_out = hn::Set(dout, kInf);
  const auto iota = hn::Iota(di32, 0);
  HWY_ALIGN std::uint32_t columns[(kMaxRun + kA - 1) * 16];  // H(c, k0 ..) of the run's columns
  for (int x = 0; x < w;) {
    const int lo = lo_row[x];
    if (count_row[x] == 0) {
      for (int k = 0; k < stride; ++k) out[k] = kInf;  // lo may lie anywhere: read nothing
      ++x;
      out += stride;
      continue;
    }
    int end = x + 1, most = count_row[x];
    for (; end < w && end - x < kMaxRun && lo_row[end] == lo && count_row[end] > 0; ++end)
      most = std::max<int>(most, count_row[end]);
    const int run = end - x;
    // Vectors wholly past the count hold only kSgmInf: at the finer levels most pixels use less
    // than half of a slot of 32 (14.5 candidates on average in quality at 640 x 480).
    int k0 = 0;
    for (; k0 < most; k0 += n) {
      for (int c = 0; c < run + kA - 1; ++c) {
        // Column x - h + c of the left view against mirrored column w - 1 - (x - h + c) + lo + k0.
        const int col = x - kH + c;
        auto acc = hn::Zero(du32);
        for (int j = 0; j < kA; ++j) {
          for (int word = 0; word < kWords; ++word) {
            const auto l = hn::Set(du32, left[j * kWords + word][col]);
            const auto r = hn::LoadU(du32, mirror[j * kWords + word] + (w - 1 - col + lo + k0));
            acc = hn::Add(acc, hn::PopulationCount(hn::Xor(l, r)));
          }
        }
        hn::Store(acc, du32, columns + c * n);
      }
      const auto candidate = hn::Add(iota, hn::Set(di32, k0));
      for (int p = 0; p < run; ++p) {
        auto sum = hn::Load(du32, columns + p * n);
        for (int i = 1; i < kA; ++i) sum = hn::Add(sum, hn::Load(du32, columns + (p + i) * n));
        // Costs are at most 9 x 9 x 80, and below kSgmInf8 with byte entries: the saturating
        // demotion is exact for them and takes kSgmInf to the entries' largest value.
        const auto in_band = hn::Lt(candidate, hn::Set(di32, count_row[x + p]));
        hn::StoreU(hn::DemoteTo(dout, hn::IfThenElse(in_band, hn::BitCast(di32, sum), inf)), dout,
                   out + p * stride + k0);
      }
    }
    for (int p = 0; p < run; ++p)
      for (int k = k0; k < stride; k += n) hn::StoreU(inf_out, dout, out + p * stride + k);
    x = end;
    out += run * stride;
  }
}

template <class T>
using RowCostsFn = void (*)(const std::uint32_t* const*, const std::uint32_t* const*, int, const std::int16_t*,
                            const std::int16_t*, int, T*);

template <int kWords, class T>
RowCostsFn<T> RowCostsFor(int a) {
  switch (a) {
    case 1: return &RowCosts<kWords, 1, T>;
    case 3: return &RowCosts<kWords, 3, T>;
    case 5: return &RowCosts<kWords, 5, T>;
    case 7: return &RowCosts<kWords, 7, T>;
    default: return &RowCosts<kWords, 9, T>;
  }
}

template <class T>
RowCostsFn<T> RowCostsOf(int words, int a) {
  return words == 1 ? RowCostsFor<1, T>(a) : words == 2 ? RowCostsFor<2, T>(a) : RowCostsFor<3, T>(a);
}

// The coarse row's bands for RowBands().
struct CoarseRowBands {
  const int *lo, *hi, *centre;
  const int *narrow_lo, *narrow_hi;  // the temporal radius's (temporal prior only)
};

// Six int16 rows of the level's width plus kRangeSegmentSlack for the temporal prior: the coarser
// map's bands of both radii per pixel, then the result.
struct TemporalRows {
  std::int16_t *band_lo, *band_hi, *narrow_lo, *narrow_hi, *lo, *hi;
};

// The coarse row's bands of both radii per fine pixel x (coarse column min(x / 2, cw - 1)), as
// the temporal prior reads them: made once per coarse row, which serves two fine rows.
void ReplicateCoarseBands(int w, int cw, const CoarseRowBands& coarse, const TemporalRows& rows) {
  for (int x = 0; x < w; ++x) {
    const int cx = std::min(x / 2, cw - 1);
    rows.band_lo[x] = static_cast<std::int16_t>(coarse.lo[cx]);
    rows.band_hi[x] = static_cast<std::int16_t>(coarse.hi[cx]);
    rows.narrow_lo[x] = static_cast<std::int16_t>(coarse.narrow_lo[cx]);
    rows.narrow_hi[x] = static_cast<std::int16_t>(coarse.narrow_hi[cx]);
  }
}

// The temporal prior's band of every pixel of row y before the clip to the image
// (with_temporal_prior()), into rows.lo and rows.hi, from ReplicateCoarseBands()'s rows.
void TemporalRowBands(const SgmBandConfig& config, int w, int y, const TemporalRows& rows) {
  // Segments may write past their end: each later one rewrites what the one before spilled.
  for (int x = 0; x < w; x += kTemporalSegment)
    TemporalRangeSegment(config.temporal, y, x, std::min(x + kTemporalSegment, w), config.dmin, config.dmax,
                         rows.band_lo + x, rows.band_hi + x, rows.narrow_lo + x, rows.narrow_hi + x, rows.lo + x,
                         rows.hi + x);
}

// The band of every pixel of row y (sgm_band_at()), from the coarse row's bands (null: no prior),
// with the temporal prior from ReplicateCoarseBands()'s rows through TemporalRowBands().
void RowBands(const SgmBandConfig& config, int w, int y, int cw, const CoarseRowBands* coarse,
              const TemporalRows* temporal, std::int16_t* lo_row, std::int16_t* count_row) {
  if (temporal != nullptr) TemporalRowBands(config, w, y, *temporal);
  for (int x = 0; x < w; ++x) {
    int lo = config.dmin, hi = config.dmax, centre = (config.dmin + config.dmax) >> 1;
    if (coarse != nullptr) {
      const int cx = std::min(x / 2, cw - 1);
      lo = temporal != nullptr ? temporal->lo[x] : coarse->lo[cx];
      hi = temporal != nullptr ? temporal->hi[x] : coarse->hi[cx];
      centre = coarse->centre[cx];
    }
    lo = std::max(lo, x - w + 1);
    hi = std::min(hi, x);
    if (hi - lo + 1 > config.max_band) {
      lo = std::clamp(centre - config.max_band / 2, lo, hi - config.max_band + 1);
      hi = lo + config.max_band - 1;
    }
    lo_row[x] = static_cast<std::int16_t>(lo);
    count_row[x] = static_cast<std::int16_t>(std::max(hi - lo + 1, 0));
  }
}

// Mirrors the rows of the right view's codes that the windows of rows [first, last) read (all of
// them into planes of the level's height, else a window of rows from mirror_row0 into planes of
// a segment's).
void SgmMirrorRows(const CensusCodes& right, int shd_window, SgmVolume& v, int first, int last) {
  const int h = v.height, hr = shd_window / 2;
  const int r0 = std::max(first - hr, 0), r1 = std::min(last + hr, h);
  v.mirror_row0 = v.mirrored[0].height() >= h ? 0 : r0;
  if (r1 - v.mirror_row0 > v.mirrored[0].height()) std::abort();  // planes too short for the window
  MirrorCodes(right, r0, r1, v);
}

// Bands and costs of rows [first, last), after mirroring the codes their windows read unless
// `mirrored` (SgmMirrorRows() of those rows or more has run).
void SgmCostsRows(const CensusCodes& left, const CensusCodes& right, const Plane<std::int16_t>* coarse,
                  const SgmBandConfig& config, int shd_window, SgmScratch& scratch, SgmVolume& v, int first,
                  int last, bool mirrored) {
  const int w = v.width, h = v.height, words = left.words, hr = shd_window / 2;
  if (!mirrored) SgmMirrorRows(right, shd_window, v, first, last);
  // The row's costs into the volume's entries, bytes or u16.
  const RowCostsFn<std::uint8_t> byte_costs = v.cost8 ? RowCostsOf<std::uint8_t>(words, shd_window) : nullptr;
  const RowCostsFn<std::uint16_t> wide_costs = v.cost8 ? nullptr : RowCostsOf<std::uint16_t>(words, shd_window);
  const int cw = coarse ? coarse->width() : 1;
  if (t_pool && t_pool->size() > scratch.threads) std::abort();  // a scratch slice per thread
  parallel_for(
      last - first, 4,
      [&](int i0, int i1) {
        const int y0 = first + i0, y1 = first + i1;
        // Seven int rows of the coarse width per thread (sgm_scratch_bytes holds seven of the level's
        // width), then the temporal prior's rows.
        int* lo_c = reinterpret_cast<int*>(scratch.data.get() + thread_slot() * scratch.bytes_per_thread);
        int *hi_c = lo_c + cw, *centre_c = hi_c + cw, *col_min = centre_c + cw, *col_max = col_min + cw;
        int *narrow_lo_c = col_max + cw, *narrow_hi_c = narrow_lo_c + cw;
        const bool temporal = config.temporal.on() && coarse != nullptr;
        if (!temporal) narrow_lo_c = narrow_hi_c = nullptr;
        const CoarseRowBands row_bands{lo_c, hi_c, centre_c, narrow_lo_c, narrow_hi_c};
        // Then the temporal prior's int16 rows, 64-byte aligned.
        const std::size_t row16 = (static_cast<std::size_t>(w) + kRangeSegmentSlack + 31) / 32 * 32;
        std::int16_t* t0 = reinterpret_cast<std::int16_t*>(
            reinterpret_cast<std::uint8_t*>(lo_c) + (7 * static_cast<std::size_t>(cw) * sizeof(int) + 63) / 64 * 64);
        const TemporalRows temporal_rows{t0, t0 + row16, t0 + 2 * row16, t0 + 3 * row16, t0 + 4 * row16,
                                         t0 + 5 * row16};
        int last_cy = -1;  // the coarse row whose bands lo_c .. narrow_hi_c hold, within this chunk
        for (int y = y0; y < y1; ++y) {
          if (coarse != nullptr) {
            const int cy = std::min(y / 2, coarse->height() - 1);
            if (cy != last_cy) {
              coarse_bands(*coarse, config, cy, lo_c, hi_c, centre_c, col_min, col_max, narrow_lo_c, narrow_hi_c);
              if (temporal) ReplicateCoarseBands(w, cw, row_bands, temporal_rows);
            }
            last_cy = cy;
          }
          RowBands(config, w, y, cw, coarse != nullptr ? &row_bands : nullptr, temporal ? &temporal_rows : nullptr,
                   v.lo.row(y), v.count.row(y));
          const std::uint32_t* left_rows[9 * 3];
          const std::uint32_t* mirror_rows[9 * 3];
          for (int j = 0; j < shd_window; ++j) {
            const int yy = clamp_index(y - hr + j, h);
            for (int k = 0; k < words; ++k) {
              left_rows[j * 3 + k] = left.plane[k].row(yy);
              mirror_rows[j * 3 + k] = v.mirrored_row(k, yy);
            }
          }
          if (byte_costs)
            byte_costs(left_rows, mirror_rows, w, v.lo.row(y), v.count.row(y), v.stride, v.cost8_at(0, y));
          else
            wide_costs(left_rows, mirror_rows, w, v.lo.row(y), v.count.row(y), v.stride, v.cost_at(0, y));
        }
      },
      scratch.threads);
}

void SgmCosts(const CensusCodes& left, const CensusCodes& right, const Plane<std::int16_t>* coarse,
              const SgmBandConfig& config, int shd_window, SgmScratch& scratch, SgmVolume& v) {
  SgmCostsRows(left, right, coarse, config, shd_window, scratch, v, 0, v.height, false);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(SgmCostsRows);
HWY_EXPORT(SgmMirrorRows);
void sgm_costs_rows(const CensusCodes& left, const CensusCodes& right, const Plane<std::int16_t>* coarse,
                    const SgmBandConfig& config, int shd_window, SgmScratch& scratch, SgmVolume& volume, int first,
                    int last, bool mirrored) {
  HWY_DYNAMIC_DISPATCH(SgmCostsRows)(left, right, coarse, config, shd_window, scratch, volume, first, last, mirrored);
}
void sgm_mirror_rows(const CensusCodes& right, int shd_window, SgmVolume& volume, int first, int last) {
  HWY_DYNAMIC_DISPATCH(SgmMirrorRows)(right, shd_window, volume, first, last);
}
HWY_EXPORT(SgmCosts);
void sgm_costs(const CensusCodes& left, const CensusCodes& right, const Plane<std::int16_t>* coarse,
               const SgmBandConfig& config, int shd_window, SgmScratch& scratch, SgmVolume& volume) {
  HWY_DYNAMIC_DISPATCH(SgmCosts)(left, right, coarse, config, shd_window, scratch, volume);
}
}  // namespace mctstereo::detail::cpu
#endif
