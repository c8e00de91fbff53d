// SHD cost and winner-takes-all: Highway SIMD over columns, OpenMP over tiles.
//
// The image is cut into tiles of kRows rows and kTile - (a - 1) columns (a = SHD window). Per tile:
//  1. Bounds. Each pixel's candidate interval [F, L] is [lo, hi] clipped to the candidates whose
//     matching pixel x + dir d lies in the image. Their union U over the tile, and the hulls of
//     the intervals per column (over the tile's rows) and per row (over its columns).
//  2. Cost band. For each candidate d of U, the costs of the pixels that may search d, as int16 in
//     band[row][d - c0][column]. Only the rectangle of columns x rows whose hulls contain d is
//     computed, so at the finer pyramid levels (narrow ranges around a prior that varies across
//     the tile) the work follows the per-pixel range widths rather than |U| for every pixel.
//     The a x a window sum is separable. Each Hamming row H(x', y', d) (XOR + popcount of the
//     census words in u32 lanes, narrowed to int16) updates a vertical running sum over a rows
//     (add the row entering, subtract the row leaving, both in registers); the box sum is
//     then a horizontal sum of a neighbours. A cost takes one popcount per census word and O(a)
//     int16 adds instead of a * a popcounts. With a tile a - 1 columns narrower than kTile, a
//     full-width Hamming row (tile plus window margins) is exactly kTile columns, whole vectors.
//  3. Winner-takes-all over the band, vectorised over the pixels of a row (WtaBest, WtaSecond;
//     over pixels rather than candidates because at the finer levels a pixel has only 5..12
//     candidates, fewer than the lanes), then the Q4 disparities, the sub-pixel offset and the
//     uniqueness test (Finalize).
// Cost and WTA are separate passes over the band on purpose: a cost aggregation stage
// (semi-global paths) can later sit between them.
//
// A union wider than the scratch band (more than kMaxChunk candidates) goes through the band in
// chunks; a one-pass WTA (WtaChunkSteps) then carries every pixel's state from chunk to chunk,
// which gives the same result because the candidates are still visited in increasing order.
//
// Exactness: costs are at most 9 * 9 * 80 = 6480, so int16 lanes never overflow, and kInf =
// INT16_MAX is larger than any cost. Code planes carry kCodePad = 8 replicated columns and a
// valid candidate's window reads columns in [-4, w + 4), so reading the planes directly is
// exactly the reference's clamped read (vector overrun past that stays in the rows' 64-byte
// slack and only feeds lanes that are never used). Rows are clamped through the row pointers.

#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/match.cpp"
// AVX3_DL (Ice Lake and later) has a native 32-bit popcount (VPOPCNTDQ), which this stage lives
// on; Highway 1.0.3 compiles that target only on request.
#ifndef HWY_WANT_AVX3_DL
#define HWY_WANT_AVX3_DL
#endif
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/min_lanes-inl.h"
#include "cpu/search_range-inl.h"
#include "cpu/vec_slot-inl.h"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "cpu/match_tiles.hpp"
#include "cpu/parallel.hpp"
#include "stages.hpp"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;
using namespace match_layout;

constexpr std::int16_t kInf = INT16_MAX;

// At most 64-byte vectors: the planes guarantee 64 bytes of slack after each row, no more.
using D16 = hn::CappedTag<std::int16_t, kMaxLanes16>;
using DU32 = hn::CappedTag<std::uint32_t, 16>;
using DI32 = hn::RebindToSigned<DU32>;
using D16H = hn::Rebind<std::int16_t, DU32>;  // int16 lanes, as many as DU32 has
using V16 = hn::Vec<D16>;

// Per-tile bounds of the candidate intervals (absolute disparities; an empty interval is stored as
// F = INT16_MAX, L = INT16_MIN so that it never widens a min/max hull).
struct TileBounds {
  alignas(64) std::int16_t F[kRows][kTile];
  alignas(64) std::int16_t L[kRows][kTile];
  alignas(64) std::int16_t col_f[kTile];
  alignas(64) std::int16_t col_l[kTile];
  std::int16_t row_f[kRows], row_l[kRows];
};

// Row pointers of both code planes for the tile rows -4 .. kRows + 3 (clamped to the image).
struct TileRows {
  int x0;
  const std::uint32_t* ref[3][kRows + 8];
  const std::uint32_t* other[3][kRows + 8];
};

template <int kWords>
HWY_INLINE hn::Vec<DU32> Popcounts(const std::uint32_t* const* rp, const std::uint32_t* const* op, int j) {
  const DU32 du32;
  auto pc = hn::PopulationCount(hn::Xor(hn::LoadU(du32, rp[0] + j), hn::LoadU(du32, op[0] + j)));
  if constexpr (kWords > 1)
    pc = hn::Add(pc, hn::PopulationCount(hn::Xor(hn::LoadU(du32, rp[1] + j), hn::LoadU(du32, op[1] + j))));
  if constexpr (kWords > 2)
    pc = hn::Add(pc, hn::PopulationCount(hn::Xor(hn::LoadU(du32, rp[2] + j), hn::LoadU(du32, op[2] + j))));
  return pc;
}

#if HWY_TARGET != HWY_SCALAR
// Two u32 vectors of popcounts (at most 96 each) as one int16 vector, columns in order.
HWY_INLINE V16 NarrowPair(hn::Vec<DU32> lo, hn::Vec<DU32> hi) {
  const D16 d16;
#if HWY_TARGET == HWY_AVX2 || HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  const DI32 di32;
  // The x86 pack works per 128-bit block (lo's 4 values, then hi's); one 64-bit lane permute
  // puts the blocks back in column order: one shuffle less than a general two-table permute.
  const V16 packed = hn::ReorderDemote2To(d16, hn::BitCast(di32, lo), hn::BitCast(di32, hi));
  const hn::Repartition<std::uint64_t, D16> d64;
#if HWY_TARGET == HWY_AVX2
  alignas(32) static constexpr std::uint64_t kOrder[4] = {0, 2, 1, 3};
#else
  alignas(64) static constexpr std::uint64_t kOrder[8] = {0, 2, 4, 6, 1, 3, 5, 7};
#endif
  return hn::BitCast(d16, hn::TableLookupLanes(hn::BitCast(d64, packed), hn::SetTableIndices(d64, kOrder)));
#elif HWY_TARGET == HWY_SSE4 || HWY_TARGET == HWY_SSSE3 || HWY_TARGET == HWY_EMU128
  const DI32 di32;
  return hn::ReorderDemote2To(d16, hn::BitCast(di32, lo), hn::BitCast(di32, hi));  // in order
#else
  // Elsewhere the low halves of the u32 lanes are the values.
  const hn::RebindToUnsigned<D16> du16;
  return hn::BitCast(d16, hn::ConcatEven(du16, hn::BitCast(du16, hi), hn::BitCast(du16, lo)));
#endif
}
#endif

// Costs of candidate d for the tile columns [xa, xb) and rows [ya, yb) (tile-local), into
// band[(r * kc + d - c0) * kTile + x]. First all vertical sums (one V row per output row), then
// all horizontal sums: the box sums read V with unaligned loads that straddle the stores which
// wrote it, and reading a row right after writing it would stall on store-to-load forwarding
// (measured: 20 % of the whole stage); a whole pass later those stores have reached the cache.
// The vertical sums go column vector by column vector, down the rows: the running sum and the a
// Hamming rows inside the window stay in registers (the window shifts by moves at fixed indices,
// which the compiler renames away), so a V row costs one store and no load. Measured 5 % faster
// on the whole stage than V rows built from the previous one and a ring of Hamming rows in memory.
template <int kWords, int kA>
void CostRectangle(const TileRows& tr, int s, int d, int xa, int xb, int ya, int yb,
                   std::int16_t* band, int kc, int c0, std::int16_t* vrows, int row_step) {
  constexpr int kH = kA / 2;
  const int n = xb - xa + 2 * kH;  // columns of V: the output columns and the margins
  const int gx = tr.x0 + xa - kH;  // image column of V[0]
  const int outs = yb - ya;
  // Hamming row rr is tile row ya - kH + rr.
  const std::uint32_t* rp[kRows + 8][kWords];
  const std::uint32_t* op[kRows + 8][kWords];
  for (int rr = 0; rr < outs + kA - 1; ++rr) {
    const int t = ya - kH + rr + 4;  // TileRows starts at tile row -4
    for (int k = 0; k < kWords; ++k) {
      rp[rr][k] = tr.ref[k][t] + gx;
      op[rr][k] = tr.other[k][t] + gx + s;
    }
  }
  std::int16_t* v0 = vrows + kVFront;
  // The V column vector at j, given the Hamming costs hrow(rr, j) of its columns in row rr.
  const auto column = [&](auto dv, auto hrow, int j) {
    using VV = decltype(hrow(0, j));
    VecSlot<decltype(dv)> win[kA];
    VV v = hrow(0, j);
    win[0] = v;
    for (int rr = 1; rr < kA; ++rr) {
      win[rr] = hrow(rr, j);
      v = hn::Add(v, VV(win[rr]));
    }
    hn::StoreU(v, dv, v0 + j);
    for (int o = 1; o < outs; ++o) {
      const VV h = hrow(o + kA - 1, j);
      v = hn::Sub(hn::Add(v, h), VV(win[0]));
      for (int i = 0; i + 1 < kA; ++i) win[i] = win[i + 1];
      win[kA - 1] = h;
      hn::StoreU(v, dv, v0 + o * kVLen + j);
    }
  };
  const DU32 du32;
  const DI32 di32;
  const int N = static_cast<int>(hn::Lanes(du32));
  const auto pc = [&](int rr, int j) { return Popcounts<kWords>(rp[rr], op[rr], j); };
  int j = 0;
#if HWY_TARGET != HWY_SCALAR
  // Two u32 vectors of popcounts become one full int16 vector: the sums then run on twice the
  // lanes per instruction.
  for (; j + N < n; j += 2 * N)
    column(D16(), [&](int rr, int jj) { return NarrowPair(pc(rr, jj), pc(rr, jj + N)); }, j);
#endif
  // The rest (at most one u32 vector on SIMD targets) a half at a time.
  const D16H d16h;
  for (; j < n; j += N)
    column(d16h, [&](int rr, int jj) { return hn::DemoteTo(d16h, hn::BitCast(di32, pc(rr, jj))); }, j);
  // Horizontal sums: vsum[j] holds the vertical sum of column xa - h + j, so the box of column x
  // starts at x - xa. Stores start at a vector boundary of the band row.
  const D16 d16;
  const int N16 = static_cast<int>(hn::Lanes(d16));
  const int xs = xa - xa % N16;
  for (int o = 0; o < outs; ++o) {
    // With MatchConfig::even_rows the odd rows need no costs (tiles start at even image rows, so
    // a tile row's parity is the image row's); their running vertical sums still pass through.
    if ((ya + o) % row_step != 0) continue;
    const std::int16_t* vsum = v0 + o * kVLen;
    std::int16_t* dst = band + ((ya + o) * kc + (d - c0)) * kTile;
    for (int x = xs; x < xb; x += N16) {
      const std::int16_t* v = vsum + (x - xa);
      V16 sum = hn::LoadU(d16, v);
      for (int i = 1; i < kA; ++i) sum = hn::Add(sum, hn::LoadU(d16, v + i));
      hn::Store(sum, d16, dst + x);
    }
  }
}

using CostFn = void (*)(const TileRows&, int, int, int, int, int, int, std::int16_t*, int, int,
                        std::int16_t*, int);

template <int kWords>
CostFn CostFor(int a) {
  switch (a) {
    case 1: return &CostRectangle<kWords, 1>;
    case 3: return &CostRectangle<kWords, 3>;
    case 5: return &CostRectangle<kWords, 5>;
    case 7: return &CostRectangle<kWords, 7>;
    default: return &CostRectangle<kWords, 9>;
  }
}

// WTA result of one vector of pixels.
struct WtaState {
  using Slot = VecSlot<D16>;
  Slot bc, bd;       // best cost (kInf: no candidate) and its disparity
  Slot cm1, cp1;     // costs at bd - 1 and bd + 1 (read only where both are candidates)
  Slot sec;          // smallest cost outside bd - 1 .. bd + 1 (kInf: none)
  Slot pmin, pmin2;  // chunked pass only: smallest cost up to d - 1 and up to d - 2
  Slot prev;         // chunked pass only: cost at d - 1
  // Defined here, so that it carries the target's attributes: GCC's implicit constructor does not,
  // and cannot inline the vectors' constructors on aarch64 ("target specific option mismatch").
  WtaState() {}
};

// Lanes whose winner has candidates on both sides (bd - 1 and bd + 1 inside F .. L).
HWY_INLINE auto Flanked(const WtaState& st, V16 f, V16 l) {
  const V16 bd = st.bd;
  return hn::And(hn::Gt(bd, f), hn::Lt(bd, l));
}

// Per-lane candidate test as one unsigned compare: d is a candidate of the lane iff
// (d - F) mod 2^16 <= wid, wid = L - F. Empty lanes (F = INT16_MAX > L) get wid = 0, which
// only d = INT16_MAX could pass; disparities stay far below (Q4 output limits them to 2047).
HWY_INLINE hn::Vec<hn::RebindToUnsigned<D16>> CandidateWidth(V16 f, V16 l) {
  const hn::RebindToUnsigned<D16> du16;
  return hn::BitCast(du16, hn::IfThenZeroElse(hn::Gt(f, l), hn::Sub(l, f)));
}

// Best cost and disparity over candidates dlo..dhi (all in the band), ties to the smaller d:
// a strict "<" while d increases. rel = d - F runs along with d, so the candidate test is a
// single compare. The loop-carried chains are one instruction long (bc through a min, the
// others through one select each), so consecutive candidates overlap. With kSubpixel the costs
// beside the winner come along: cm1 is the cost one step before a new best, cp1 the cost one
// step after the current best (both only read where bd - 1 and bd + 1 are candidates).
template <bool kSubpixel>
HWY_INLINE void WtaBest(const std::int16_t* col, int c0, int dlo, int dhi, V16 f, V16 l, WtaState& st) {
  const D16 d16;
  const hn::RebindToUnsigned<D16> du16;
  const auto wid = CandidateWidth(f, l);
  const V16 one = hn::Set(d16, 1);
  const V16 inf = hn::Set(d16, kInf);
  V16 rel = hn::Sub(hn::Set(d16, static_cast<std::int16_t>(dlo)), f);
  V16 bc = inf, brp1 = hn::Zero(d16);  // brp1: rel of the best + 1
  V16 prev = inf, cm1 = inf, cp1 = inf;
  for (int d = dlo; d <= dhi; ++d) {
    const V16 c = hn::Load(d16, col + (d - c0) * kTile);
    const V16 ce = hn::IfThenElse(hn::RebindMask(d16, hn::Gt(hn::BitCast(du16, rel), wid)), inf, c);
    const auto better = hn::Lt(ce, bc);
    const V16 rel_next = hn::Add(rel, one);
    if constexpr (kSubpixel) {
      cp1 = hn::IfThenElse(hn::Eq(rel, brp1), c, cp1);
      cm1 = hn::IfThenElse(better, prev, cm1);
      prev = c;
    }
    brp1 = hn::IfThenElse(better, rel_next, brp1);
    bc = hn::Min(bc, ce);
    rel = rel_next;
  }
  st.bc = bc;
  st.bd = hn::Add(hn::Sub(brp1, one), f);
  st.cm1 = cm1;
  st.cp1 = cp1;
}

// Second best outside bd - 1 .. bd + 1 over the whole candidate interval of each lane.
HWY_INLINE void WtaSecond(const std::int16_t* col, int c0, int dlo, int dhi, V16 f, V16 l, WtaState& st) {
  const D16 d16;
  const hn::RebindToUnsigned<D16> du16;
  const auto wid = CandidateWidth(f, l);
  const V16 one = hn::Set(d16, 1);
  const V16 inf = hn::Set(d16, kInf);
  const V16 bm1 = hn::Sub(st.bd, one), bp1 = hn::Add(st.bd, one);
  V16 rel = hn::Sub(hn::Set(d16, static_cast<std::int16_t>(dlo)), f);
  V16 dv = hn::Set(d16, static_cast<std::int16_t>(dlo));
  V16 sec = hn::Set(d16, kInf);
  for (int d = dlo; d <= dhi; ++d, rel = hn::Add(rel, one), dv = hn::Add(dv, one)) {
    const V16 c = hn::Load(d16, col + (d - c0) * kTile);
    const auto cand = hn::RebindMask(d16, hn::Not(hn::Gt(hn::BitCast(du16, rel), wid)));
    const auto far = hn::Or(hn::Lt(dv, bm1), hn::Gt(dv, bp1));
    sec = hn::Min(sec, hn::IfThenElse(hn::And(cand, far), c, inf));
  }
  st.sec = sec;
}

// The same result in one pass whose state can stop and resume between chunks of candidates.
// Lanes that do not search d see cost kInf, which never wins and never lowers a minimum, so they
// behave as if the candidate were skipped. When d becomes the best: cm1 is the cost just seen at
// d - 1; the second best outside d - 1 .. d + 1 restarts as the minimum up to d - 2 (everything
// seen so far except d - 1); cp1 is filled by the next candidate; later candidates beyond d + 1
// lower the second best.
template <bool kTrack, bool kUnique>
HWY_INLINE void WtaChunkSteps(const std::int16_t* col, int c0, int dlo, int dhi, V16 f, V16 l, WtaState& st) {
  const D16 d16;
  const V16 inf = hn::Set(d16, kInf);
  const V16 one = hn::Set(d16, 1);
  V16 dv = hn::Set(d16, static_cast<std::int16_t>(dlo));
  for (int d = dlo; d <= dhi; ++d, dv = hn::Add(dv, one)) {
    const V16 c = hn::Load(d16, col + (d - c0) * kTile);
    const V16 ce = hn::IfThenElse(hn::Or(hn::Lt(dv, f), hn::Gt(dv, l)), inf, c);
    const auto better = hn::Lt(ce, st.bc);
    if constexpr (kTrack) {
      const auto next = hn::Eq(dv, hn::Add(st.bd, one));  // d == old best + 1
      st.cm1 = hn::IfThenElse(better, st.prev, st.cm1);
      st.cp1 = hn::IfThenElse(better, inf, hn::IfThenElse(next, ce, st.cp1));
      st.prev = ce;
      if constexpr (kUnique) {
        st.sec = hn::IfThenElse(better, st.pmin2, hn::IfThenElse(next, st.sec, hn::Min(st.sec, ce)));
        st.pmin2 = st.pmin;
        st.pmin = hn::Min(st.pmin, ce);
      }
    }
    st.bc = hn::Min(st.bc, ce);
    st.bd = hn::IfThenElse(better, dv, st.bd);
  }
}

#if HWY_TARGET == HWY_SCALAR
// One lane: the reference's integer arithmetic directly.
template <bool kSubpixel, bool kUnique>
HWY_INLINE V16 Finalize(const WtaState& st, V16 f, V16 l, int uniqueness_ratio) {
  const D16 d16;
  const int bc = hn::GetLane(st.bc), bd = hn::GetLane(st.bd);
  if (bc == kInf) return hn::Set(d16, kInvalid);
  if constexpr (kUnique) {
    const int sec = hn::GetLane(st.sec);
    if (uniqueness_ratio > 0 && sec != kInf && 100 * (sec - bc) <= uniqueness_ratio * bc)
      return hn::Set(d16, kInvalid);
  }
  int q4 = 16 * bd;
  if constexpr (kSubpixel) {
    if (bd > hn::GetLane(f) && bd < hn::GetLane(l))
      q4 += subpixel_offset_q4(hn::GetLane(st.cm1), bc, hn::GetLane(st.cp1));
  }
  return hn::Set(d16, static_cast<std::int16_t>(q4));
}
#else
// Q4 disparities of one vector of pixels, as the reference computes them. The parts that need
// more than 16 bits run on the two halves promoted to int32.
template <bool kSubpixel, bool kUnique>
HWY_INLINE V16 Finalize(const WtaState& st, V16 f, V16 l, int uniqueness_ratio) {
  const D16 d16;
  const V16 inf = hn::Set(d16, kInf);
  // 16 * d wraps in int16 exactly like the reference's cast (|d| < 2048 in practice anyway).
  V16 q4 = hn::ShiftLeft<4>(st.bd);
  auto invalid = hn::Eq(st.bc, inf);
  if constexpr (kSubpixel || kUnique) {
    const hn::Half<D16> dh;
    const hn::Repartition<std::int32_t, D16> d32;
    const hn::Rebind<float, decltype(d32)> df;
    const auto lower = [&](V16 v) { return hn::PromoteTo(d32, hn::LowerHalf(dh, v)); };
    const auto upper = [&](V16 v) { return hn::PromoteTo(d32, hn::UpperHalf(dh, v)); };
    const auto narrow = [&](hn::Vec<decltype(d32)> hi, hn::Vec<decltype(d32)> lo) {
      return hn::Combine(d16, hn::DemoteTo(dh, hi), hn::DemoteTo(dh, lo));
    };
    if constexpr (kSubpixel) {
      // subpixel_offset_q4 with e = c0 - 2 c1 + c2 > 0: q = floor((16 |c0 - c2| + e) / (2 e)),
      // 0 <= q <= 8. e and |c0 - c2| fit int16 (<= 12960 and 6480); lanes that are not ok may
      // wrap, and whatever they compute is masked below. In float the operands are exact
      // (< 2^18) and the quotient is at most 8.5 (|c0 - c2| <= e); when it is not an integer it
      // lies at least 1 / (2 e) > 2^-15 below the next one, far more than the rounding error of
      // the division (<= 2^-21 there), so truncating the float quotient gives q. (Checked for
      // every pair 0 <= |c0 - c2| <= e <= 12960 as well.)
      const auto ok = Flanked(st, f, l);
      const V16 e = hn::Add(hn::Sub(st.cm1, hn::ShiftLeft<1>(st.bc)), st.cp1);
      const V16 ad = hn::Abs(hn::Sub(st.cm1, st.cp1));
      const auto offset = [&](hn::Vec<decltype(d32)> ad32, hn::Vec<decltype(d32)> e32) {
        const auto num = hn::ConvertTo(df, hn::Add(hn::ShiftLeft<4>(ad32), e32));
        const auto den = hn::ConvertTo(df, hn::ShiftLeft<1>(e32));
        return hn::ConvertTo(d32, hn::Div(num, den));
      };
      const V16 q = narrow(offset(upper(ad), upper(e)), offset(lower(ad), lower(e)));
      const V16 signed_q = hn::IfThenElse(hn::Lt(st.cm1, st.cp1), hn::Neg(q), q);
      q4 = hn::Add(q4, hn::IfThenElseZero(ok, signed_q));
    }
    if (kUnique && uniqueness_ratio > 0) {
      // 100 (sec - bc) <= ratio bc  <=>  100 sec <= (100 + ratio) bc.
      const auto k100 = hn::Set(d32, 100), kr = hn::Set(d32, 100 + uniqueness_ratio);
      const auto fails = [&](hn::Vec<decltype(d32)> sec, hn::Vec<decltype(d32)> bc) {
        return hn::VecFromMask(d32, hn::Not(hn::Gt(hn::Mul(k100, sec), hn::Mul(kr, bc))));
      };
      const V16 fail = narrow(fails(upper(st.sec), upper(st.bc)), fails(lower(st.sec), lower(st.bc)));
      invalid = hn::Or(invalid, hn::And(hn::MaskFromVec(fail), hn::Lt(st.sec, inf)));
    }
  }
  return hn::IfThenElse(invalid, hn::Set(d16, kInvalid), q4);
}
#endif

// The margin sgm_margin(bc, sec, flanked) = 255 (sec - bc) / sec of one vector of pixels: where a
// pixel has no second best (sec = kInf), 255 if its winner bd is flanked (F < bd < L), else 0; 0
// where it has no candidate (bc = kInf) or sec = 0.
HWY_INLINE V16 MarginOf(const WtaState& st, V16 f, V16 l) {
  const D16 d16;
  const V16 bc = st.bc, sec = st.sec;
#if HWY_TARGET == HWY_SCALAR
  const int b = hn::GetLane(bc), s = hn::GetLane(sec), bd = hn::GetLane(st.bd);
  const bool flanked = bd > hn::GetLane(f) && bd < hn::GetLane(l);
  return hn::Set(d16, static_cast<std::int16_t>(
                          b == kInf ? 0 : sgm_margin(b, s == kInf ? std::numeric_limits<int>::max() : s, flanked)));
#else
  // In float: 255 (sec - bc) <= 255 x 6480 < 2^24 and sec are exact, and the quotient (<= 255),
  // where it is not an integer, lies at least 1 / sec >= 1 / 6480 below the next one, far more
  // than the rounding error of the division (255 x 2^-24), so truncation gives the integer
  // quotient. Lanes masked below (sec = 0) divide by 1 instead, so that no lane makes a NaN.
  const hn::Half<D16> dh;
  const hn::Repartition<std::int32_t, D16> d32;
  const hn::Rebind<float, decltype(d32)> df;
  const auto quotient = [&](V16 b16, V16 s16, auto half) {
    const auto b = hn::PromoteTo(d32, half(b16)), s = hn::PromoteTo(d32, half(s16));
    const auto num = hn::ConvertTo(df, hn::Mul(hn::Set(d32, 255), hn::Sub(s, b)));
    return hn::DemoteTo(dh, hn::ConvertTo(d32, hn::Div(num, hn::ConvertTo(df, hn::Max(s, hn::Set(d32, 1))))));
  };
  const V16 q = hn::Combine(d16, quotient(bc, sec, [&](V16 v) { return hn::UpperHalf(dh, v); }),
                            quotient(bc, sec, [&](V16 v) { return hn::LowerHalf(dh, v); }));
  const V16 inf = hn::Set(d16, kInf);
  const auto flanked = Flanked(st, f, l);
  const auto no_second = hn::AndNot(hn::Eq(bc, inf), hn::Eq(sec, inf));
  const auto zero = hn::Or(hn::Or(hn::Eq(bc, inf), hn::Eq(sec, hn::Zero(d16))), hn::AndNot(flanked, no_second));
  return hn::IfThenElse(hn::And(no_second, flanked), hn::Set(d16, 255), hn::IfThenZeroElse(zero, q));
#endif
}

// WTA over band candidates c0..c1 for every pixel of the tile. With the whole union in the band
// (first && last), a pass for the winner and, for uniqueness, a second pass for the second best.
// Otherwise the one-pass state is carried from chunk to chunk. The state of every pixel goes
// through the scratch either way, and the disparities are formed in a pass of their own once the
// last candidate is seen: kept apart from the candidate loops, whose trip counts vary, the
// arithmetic of many pixels overlaps. (That pass stays in this function: as a function of its own,
// GCC 12 for aarch64 crashed compiling WtaTile's SVE code.)
template <bool kSubpixel, bool kUnique>
void WtaTile(const MatchJob& job, const TileBounds& tb, int x0, int y0, int tw, int th,
             const std::int16_t* band, int kc, int c0, int c1, bool first, bool last,
             std::int16_t* state) {
  constexpr bool kTrack = kSubpixel || kUnique;
  const D16 d16;
  const int N16 = static_cast<int>(hn::Lanes(d16));
  const V16 inf = hn::Set(d16, kInf);
  const bool whole = first && last;
  static_assert(kRows % 2 == 0, "tiles start at even rows");
  const int row_step = job.config->even_rows ? 2 : 1;
  for (int r = 0; r < th; r += row_step) {
    for (int x = 0, v = 0; x < tw; x += N16, ++v) {
      const V16 f = hn::Load(d16, tb.F[r] + x), l = hn::Load(d16, tb.L[r] + x);
      const std::int16_t* col = band + r * kc * kTile + x;
      std::int16_t* sp = state + (r * kTile + x) * kStateWords;
      WtaState st;
      if (first) {
        st.bc = st.cm1 = st.cp1 = st.sec = st.pmin = st.pmin2 = st.prev = inf;
        st.bd = hn::Zero(d16);
      } else {
        st.bc = hn::Load(d16, sp + 0 * N16);
        st.bd = hn::Load(d16, sp + 1 * N16);
        st.cm1 = hn::Load(d16, sp + 2 * N16);
        st.cp1 = hn::Load(d16, sp + 3 * N16);
        st.sec = hn::Load(d16, sp + 4 * N16);
        st.pmin = hn::Load(d16, sp + 5 * N16);
        st.pmin2 = hn::Load(d16, sp + 6 * N16);
        st.prev = hn::Load(d16, sp + 7 * N16);
      }
      // Outside the row's hull every lane would see kInf. Before the hull that leaves the initial
      // state unchanged; after it no candidate wins any more, so cm1, cp1 and sec are final.
      // Across chunks the hull is still visited contiguously and in order.
      const int dlo = std::max<int>(tb.row_f[r], c0), dhi = std::min<int>(tb.row_l[r], c1);
      if (dlo <= dhi) {
        if (whole) {
          WtaBest<kSubpixel>(col, c0, dlo, dhi, f, l, st);
          if constexpr (kUnique) WtaSecond(col, c0, dlo, dhi, f, l, st);
        } else {
          WtaChunkSteps<kTrack, kUnique>(col, c0, dlo, dhi, f, l, st);
        }
      }
      // What Finalize needs, and between chunks the whole one-pass state.
      hn::Store(st.bc, d16, sp + 0 * N16);
      hn::Store(st.bd, d16, sp + 1 * N16);
      if (kSubpixel || !last) {
        hn::Store(st.cm1, d16, sp + 2 * N16);
        hn::Store(st.cp1, d16, sp + 3 * N16);
      }
      if (kUnique || !last) hn::Store(st.sec, d16, sp + 4 * N16);
      if (!last) {
        hn::Store(st.pmin, d16, sp + 5 * N16);
        hn::Store(st.pmin2, d16, sp + 6 * N16);
        hn::Store(st.prev, d16, sp + 7 * N16);
      }
    }
  }
  if (!last) return;
  const int ratio = job.config->uniqueness_ratio;
  alignas(64) std::int16_t out[kMaxLanes16];
  alignas(64) std::int16_t margins[kMaxLanes16];
  for (int r = 0; r < th; r += row_step) {
    std::int16_t* row = job.disparity->row(y0 + r) + x0;
    for (int x = 0; x < tw; x += N16) {
      const std::int16_t* sp = state + (r * kTile + x) * kStateWords;
      WtaState st;
      st.bc = hn::Load(d16, sp + 0 * N16);
      st.bd = hn::Load(d16, sp + 1 * N16);
      st.cm1 = kSubpixel ? hn::Load(d16, sp + 2 * N16) : inf;
      st.cp1 = kSubpixel ? hn::Load(d16, sp + 3 * N16) : inf;
      st.sec = kUnique ? hn::Load(d16, sp + 4 * N16) : inf;
      const V16 f = hn::Load(d16, tb.F[r] + x), l = hn::Load(d16, tb.L[r] + x);
      const V16 q4 = Finalize<kSubpixel, kUnique>(st, f, l, ratio);
      if (kUnique && job.margin != nullptr) {
        hn::Store(MarginOf(st, f, l), d16, margins);
        std::uint8_t* m = job.margin->row(y0 + r) + x0 + x;
        for (int i = 0; i < std::min(N16, tw - x); ++i) m[i] = static_cast<std::uint8_t>(margins[i]);
      }
      // The pixels past tw belong to the next tile, which another thread may be writing: only the
      // tile's own pixels are stored, by a masked store where the target has a true one.
      if (x + N16 <= tw) {
        hn::StoreU(q4, d16, row + x);
      } else {
#if HWY_TARGET <= HWY_AVX3
        hn::BlendedStore(q4, hn::FirstN(d16, static_cast<std::size_t>(tw - x)), d16, row + x);
#else
        hn::Store(q4, d16, out);
        std::copy_n(out, tw - x, row + x);
#endif
      }
    }
  }
}

// The ranges of a tile row's coarse rows cy0, cy0 + 1, ... across the level (fine columns from 0),
// made by MatchTileRow from the prior for all the row's tiles.
struct PriorRows {
  const std::int16_t *lo, *hi;
  std::size_t stride;
  int cy0;
};

// Step 1 of a tile at (x0, y0), tw x th pixels: the candidate intervals of its pixels and their
// hulls, and their union [umin, umax] (empty: umin > umax). prior_rows: the ranges MatchTileRow
// made from the prior (null: the tile makes them).
void TileBoundsOf(const MatchJob& job, int x0, int y0, int tw, int th, const PriorRows* prior_rows, TileBounds& tb,
                  int& umin, int& umax) {
  const D16 d16;
  const int N16 = static_cast<int>(hn::Lanes(d16));
  const int w = job.ref.width;
  const int dir = job.config->dir;
  // Columns past the tile get the empty interval through vlo/vhi.
  alignas(64) std::int16_t vlo[kTile], vhi[kTile];
  for (int x = 0; x < kTile; ++x) {
    if (x < tw) {
      const int X = x0 + x;
      // Candidates with 0 <= X + dir d < w (clamping to int16 cannot change max(lo, .) / min(hi, .)).
      const int a = dir < 0 ? X - w + 1 : -X, b = dir < 0 ? X : w - 1 - X;
      vlo[x] = static_cast<std::int16_t>(std::clamp(a, INT16_MIN, INT16_MAX));
      vhi[x] = static_cast<std::int16_t>(std::clamp(b, INT16_MIN, INT16_MAX));
    } else {
      vlo[x] = INT16_MAX;
      vhi[x] = INT16_MIN;
    }
  }
  const V16 vmax = hn::Set(d16, INT16_MAX), vmin = hn::Set(d16, INT16_MIN);
  for (int x = 0; x < kTile; x += N16) {
    hn::Store(vmax, d16, tb.col_f + x);
    hn::Store(vmin, d16, tb.col_l + x);
  }
  // The ranges of a tile row: from the range planes, or made here from the prior (one coarse row
  // serves two tile rows), or the whole level range. Loads reach at most N16 - 1 <= 31 values past
  // the row's last pixel: inside a plane row's 64-byte slack, or the buffers' own.
  const SearchRanges& ranges = *job.ranges;
  alignas(64) std::int16_t made_lo[kTile + kRangeSegmentSlack] = {}, made_hi[kTile + kRangeSegmentSlack] = {};
  if (!ranges.from_planes() && ranges.prior == nullptr) {
    std::fill_n(made_lo, tw, static_cast<std::int16_t>(ranges.dmin));
    std::fill_n(made_hi, tw, static_cast<std::int16_t>(ranges.dmax));
  }
  // The temporal prior: the coarser map's band of the temporal radius (per coarse row, as the
  // band above) and the row's result, which depends on the fine row. Zeroed (as the buffers above)
  // only when the prior is on: a tile without it does not touch them.
  alignas(64) std::int16_t narrow_lo[kTile + kRangeSegmentSlack], narrow_hi[kTile + kRangeSegmentSlack];
  alignas(64) std::int16_t row_lo[kTile + kRangeSegmentSlack], row_hi[kTile + kRangeSegmentSlack];
  if (ranges.with_temporal())
    for (std::int16_t* buffer : {narrow_lo, narrow_hi, row_lo, row_hi})
      std::fill_n(buffer, kTile + kRangeSegmentSlack, std::int16_t{0});
  int made_cy = -1;
  umin = INT16_MAX;
  umax = INT16_MIN;
  for (int r = 0; r < th; ++r) {
    if (job.config->even_rows && (y0 + r) % 2 != 0) {  // no candidate: the row is not matched
      for (int x = 0; x < kTile; x += N16) {
        hn::Store(vmax, d16, tb.F[r] + x);
        hn::Store(vmin, d16, tb.L[r] + x);
      }
      tb.row_f[r] = INT16_MAX;
      tb.row_l[r] = INT16_MIN;
      continue;
    }
    const std::int16_t* lr = made_lo;
    const std::int16_t* hr = made_hi;
    if (ranges.from_planes()) {
      lr = ranges.lo->row(y0 + r) + x0;
      hr = ranges.hi->row(y0 + r) + x0;
    } else if (prior_rows != nullptr) {
      const int cy = std::min((y0 + r) / 2, ranges.prior->height() - 1);
      lr = prior_rows->lo + static_cast<std::size_t>(cy - prior_rows->cy0) * prior_rows->stride + x0;
      hr = prior_rows->hi + static_cast<std::size_t>(cy - prior_rows->cy0) * prior_rows->stride + x0;
    } else if (ranges.prior != nullptr) {
      const int cy = std::min((y0 + r) / 2, ranges.prior->height() - 1);
      if (cy != made_cy) {
        if (ranges.with_temporal())
          PriorRangeSegment(*ranges.prior, cy, x0, x0 + tw, ranges.dmin, ranges.dmax, ranges.radius, made_lo, made_hi,
                            ranges.temporal.radius, narrow_lo, narrow_hi);
        else
          PriorRangeSegment(*ranges.prior, cy, x0, x0 + tw, ranges.dmin, ranges.dmax, ranges.radius, made_lo, made_hi);
        made_cy = cy;
      }
      if (ranges.with_temporal()) {
        TemporalRangeSegment(ranges.temporal, y0 + r, x0, x0 + tw, ranges.dmin, ranges.dmax, made_lo, made_hi,
                             narrow_lo, narrow_hi, row_lo, row_hi);
        lr = row_lo;
        hr = row_hi;
      }
    }
    V16 acc_f = vmax, acc_l = vmin;
    for (int x = 0; x < tw; x += N16) {
      V16 f = hn::Max(hn::LoadU(d16, lr + x), hn::Load(d16, vlo + x));
      V16 l = hn::Min(hn::LoadU(d16, hr + x), hn::Load(d16, vhi + x));
      const auto empty = hn::Gt(f, l);
      f = hn::IfThenElse(empty, vmax, f);
      l = hn::IfThenElse(empty, vmin, l);
      hn::Store(f, d16, tb.F[r] + x);
      hn::Store(l, d16, tb.L[r] + x);
      hn::Store(hn::Min(hn::Load(d16, tb.col_f + x), f), d16, tb.col_f + x);
      hn::Store(hn::Max(hn::Load(d16, tb.col_l + x), l), d16, tb.col_l + x);
      acc_f = hn::Min(acc_f, f);
      acc_l = hn::Max(acc_l, l);
    }
    const int rf = MinLaneI16(d16, acc_f), rl = MaxLaneI16(d16, acc_l);
    tb.row_f[r] = static_cast<std::int16_t>(rf);
    tb.row_l[r] = static_cast<std::int16_t>(rl);
    umin = std::min(umin, rf);
    umax = std::max(umax, rl);
  }
}

// Row pointers of the codes of tile rows -4 .. th + 3 of the tile at (x0, y0). Rows outside the
// ones the codes hold now are never read (the window reaches a rows at most): their pointers only
// need to be valid.
TileRows TileRowsOf(const MatchJob& job, int x0, int y0, int th) {
  TileRows tr;
  tr.x0 = x0;
  for (int t = 0; t < th + 8; ++t) {
    const int y = std::clamp(clamp_index(y0 + t - 4, job.ref.height), job.ref.row_lo, job.ref.row_hi);
    for (int k = 0; k < job.ref.words; ++k) {
      tr.ref[k][t] = job.ref.row(k, y);
      tr.other[k][t] = job.other.row(k, y);
    }
  }
  return tr;
}

// The columns [xa, xb) of the tile (tile-local) whose column hulls contain d (xa >= xb: none).
HWY_INLINE void ColumnsWith(const TileBounds& tb, int tw, int d, int& xa, int& xb) {
  const D16 d16;
  const int N16 = static_cast<int>(hn::Lanes(d16));
  const V16 dv = hn::Set(d16, static_cast<std::int16_t>(d));
  xa = kTile;
  xb = 0;
  for (int x = 0; x < tw; x += N16) {
    const auto m = hn::Not(hn::Or(hn::Gt(hn::Load(d16, tb.col_f + x), dv), hn::Lt(hn::Load(d16, tb.col_l + x), dv)));
    std::uint8_t bits[8] = {};
    hn::StoreMaskBits(d16, m, bits);
    std::uint64_t b = 0;
    std::memcpy(&b, bits, sizeof b);
    if (b == 0) continue;
    xa = std::min(xa, x + std::countr_zero(b));
    xb = x + 64 - std::countl_zero(b);
  }
}

// The rows [ya, yb) of the tile whose row hulls contain d (ya >= yb: none).
HWY_INLINE void RowsWith(const TileBounds& tb, int th, int d, int& ya, int& yb) {
  ya = 0;
  yb = th;
  while (ya < th && !(tb.row_f[ya] <= d && d <= tb.row_l[ya])) ++ya;
  while (yb > ya && !(tb.row_f[yb - 1] <= d && d <= tb.row_l[yb - 1])) --yb;
}

CostFn CostOf(const MatchJob& job) {
  const int a = job.config->shd_window;
  return job.ref.words == 1 ? CostFor<1>(a) : job.ref.words == 2 ? CostFor<2>(a) : CostFor<3>(a);
}

// WtaTile over band candidates c0..c1 for the job's sub-pixel and uniqueness (or margin).
void WtaTileFor(const MatchJob& job, const TileBounds& tb, int x0, int y0, int tw, int th, const std::int16_t* band,
                int kc, int c0, int c1, bool first, bool last, std::int16_t* state) {
  const bool sub = job.config->subpixel, uniq = job.config->uniqueness_ratio > 0 || job.margin != nullptr;
  if (sub && uniq) WtaTile<true, true>(job, tb, x0, y0, tw, th, band, kc, c0, c1, first, last, state);
  else if (sub) WtaTile<true, false>(job, tb, x0, y0, tw, th, band, kc, c0, c1, first, last, state);
  else if (uniq) WtaTile<false, true>(job, tb, x0, y0, tw, th, band, kc, c0, c1, first, last, state);
  else WtaTile<false, false>(job, tb, x0, y0, tw, th, band, kc, c0, c1, first, last, state);
}

// One tile; prior_rows: the ranges MatchTileRow made from the prior (null: the tile makes them).
void MatchTileWith(const MatchJob& job, int tile, std::uint8_t* mem, std::size_t bytes, const PriorRows* prior_rows) {
  const int w = job.ref.width, h = job.ref.height;
  const int x0 = (tile % job.tiles_x) * job.tile_w, y0 = (tile / job.tiles_x) * kRows;
  const int tw = std::min(job.tile_w, w - x0), th = std::min(kRows, h - y0);
  TileBounds tb;
  int umin = 0, umax = 0;
  TileBoundsOf(job, x0, y0, tw, th, prior_rows, tb, umin, umax);
  const int row_step = job.config->even_rows ? 2 : 1;  // tiles start at even rows
  if (umin > umax) {  // no pixel of the tile has a candidate
    for (int r = 0; r < th; r += row_step) {
      std::fill_n(job.disparity->row(y0 + r) + x0, tw, kInvalid);
      if (job.margin != nullptr) std::fill_n(job.margin->row(y0 + r) + x0, tw, std::uint8_t{0});
    }
    return;
  }

  // 2 + 3, chunk by chunk.
  std::int16_t* vrows = reinterpret_cast<std::int16_t*>(mem);
  std::int16_t* state = reinterpret_cast<std::int16_t*>(mem + kVRowsBytes);
  std::int16_t* band = reinterpret_cast<std::int16_t*>(mem + kFixedBytes);
  const int cap = static_cast<int>((bytes - kFixedBytes) / (kRows * kTile * sizeof(std::int16_t)));
  const int kc = std::min(umax - umin + 1, cap);
  const CostFn cost = CostOf(job);
  const TileRows tr = TileRowsOf(job, x0, y0, th);
  for (int c0 = umin; c0 <= umax; c0 += kc) {
    const int c1 = std::min(umax, c0 + kc - 1);
    for (int d = c0; d <= c1; ++d) {
      // The columns and rows whose hulls contain d (a rectangle that may include pixels which do
      // not search d: their costs are computed and never read).
      int xa = 0, xb = 0, ya = 0, yb = 0;
      ColumnsWith(tb, tw, d, xa, xb);
      if (xa >= xb) continue;
      RowsWith(tb, th, d, ya, yb);
      if (ya >= yb) continue;
      cost(tr, job.config->dir * d, d, xa, xb, ya, yb, band, kc, c0, vrows, row_step);
    }
    WtaTileFor(job, tb, x0, y0, tw, th, band, kc, c0, c1, c0 == umin, c1 == umax, state);
  }
}

void MatchTile(const MatchJob& job, int tile, std::uint8_t* mem, std::size_t bytes) {
  MatchTileWith(job, tile, mem, bytes, nullptr);
}

// The ranges of the tile row's coarse rows, made from the prior into `buffer` (prior_rows_bytes())
// once across the level, where each tile would make its own segment of them: at the widths of a
// tile the segment's fixed costs outweighed its work (realtime at 640 x 480: 8 % of the frame in
// PriorRangeSegment). The values are the same, column by column. Null where the ranges come
// otherwise (range planes, the temporal prior, the whole level range): the tiles make them.
const PriorRows* MakePriorRows(const MatchJob& job, int tile_row, std::uint8_t* buffer, PriorRows& rows) {
  const SearchRanges& ranges = *job.ranges;
  if (buffer == nullptr || ranges.from_planes() || ranges.prior == nullptr || ranges.with_temporal()) return nullptr;
  const int w = job.ref.width, y0 = tile_row * kRows, th = std::min(kRows, job.ref.height - y0);
  const int last_cy = ranges.prior->height() - 1;
  const std::size_t stride = prior_row_entries(w);
  std::int16_t* lo = reinterpret_cast<std::int16_t*>(buffer);
  std::int16_t* hi = lo + (kRows / 2) * stride;
  rows = PriorRows{lo, hi, stride, std::min(y0 / 2, last_cy)};
  for (int cy = rows.cy0; cy <= std::min((y0 + th - 1) / 2, last_cy); ++cy) {
    const std::size_t at = static_cast<std::size_t>(cy - rows.cy0) * stride;
    PriorRangeSegment(*ranges.prior, cy, 0, w, ranges.dmin, ranges.dmax, ranges.radius, lo + at, hi + at);
  }
  return &rows;
}

void MatchTileRow(const MatchJob& job, int tile_row, std::uint8_t* mem, std::size_t bytes, std::uint8_t* prior_rows) {
  PriorRows rows;
  const PriorRows* made = MakePriorRows(job, tile_row, prior_rows, rows);
  for (int t = tile_row * job.tiles_x; t < (tile_row + 1) * job.tiles_x; ++t) MatchTileWith(job, t, mem, bytes, made);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {

HWY_EXPORT(MatchTile);
HWY_EXPORT(MatchTileRow);

void match_tile_row(const MatchJob& job, int tile_row, std::uint8_t* mem, std::size_t bytes,
                    std::uint8_t* prior_rows) {
  HWY_DYNAMIC_DISPATCH(MatchTileRow)(job, tile_row, mem, bytes, prior_rows);
}

// Per thread: the V rows and the WTA state of one tile, and a band of up to kMaxChunk
// candidates for the tile. Independent of the image size.
std::size_t match_scratch_bytes(int /*width*/, int max_range, int /*shd_window*/) {
  using namespace match_layout;
  const int chunk = std::clamp(max_range, 1, kMaxChunk);
  // + kAlignment: match() aligns each thread's slice itself.
  return kFixedBytes + static_cast<std::size_t>(chunk) * kBandBytesPerCandidate + kAlignment;
}

void match(const CensusCodes& ref, const CensusCodes& other, const SearchRanges& ranges,
           const MatchConfig& config, MatchScratch& scratch, Plane<std::int16_t>& disparity,
           Plane<std::uint8_t>* margin) {
  using namespace match_layout;
  const int w = ref.plane[0].width(), h = ref.plane[0].height();
  if (w <= 0 || h <= 0) return;
  const MatchJob job = make_match_job(CodeRows::of(ref), CodeRows::of(other), ranges, config, disparity, margin);
  const int tiles = job.tiles_x * ((h + kRows - 1) / kRows);
  // Each thread's slice starts at the next 64-byte boundary (the aligned loads need it) and must
  // still hold the fixed buffers and one candidate's band: less is a driver bug, not an input.
  const std::size_t usable = aligned_slice_bytes(scratch);
  if (usable < kFixedBytes + kBandBytesPerCandidate) std::abort();
  if (t_pool && t_pool->size() > scratch.threads) std::abort();  // a scratch slice per thread
  // Tiles differ in cost (range widths vary with the prior), hence one tile per chunk, taken as
  // threads come free; every tile writes only its own pixels, so the result does not depend on
  // the thread count or the order.
  parallel_for(
      tiles, 1,
      [&](int t0, int t1) {
        std::uint8_t* mem = aligned_slice(scratch, thread_slot());
        for (int t = t0; t < t1; ++t) HWY_DYNAMIC_DISPATCH(MatchTile)(job, t, mem, usable);
      },
      scratch.threads);
}

}  // namespace mctstereo::detail::cpu
#endif  // HWY_ONCE
