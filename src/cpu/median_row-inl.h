// The k x k median of one row of a disparity map (k = 3, 5), per SIMD target: the median filter
// stage (median_filter.cpp) and the finest level's refinement in strips (refine_left_map.cpp)
// share it. Min/max selection networks on int16 lanes, one vector of output pixels at a time.
// Invalid pixels are INT16_MIN, so they enter as the smallest value without any special case,
// exactly as in the reference. Included after <hwy/highway.h> by files that use
// foreach_target.h; the toggled guard is Highway's idiom for that.
#if defined(MCTSTEREO_CPU_MEDIAN_ROW_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef MCTSTEREO_CPU_MEDIAN_ROW_INL_H_
#undef MCTSTEREO_CPU_MEDIAN_ROW_INL_H_
#else
#define MCTSTEREO_CPU_MEDIAN_ROW_INL_H_
#endif

#include <hwy/highway.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <utility>

#include "cpu/vec_slot-inl.h"
#include "stages.hpp"

#ifndef MCTSTEREO_CPU_MEDIAN_NETWORKS
#define MCTSTEREO_CPU_MEDIAN_NETWORKS
namespace mctstereo::detail::cpu {

// One comparator of a selection network: afterwards wire a holds the smaller and wire b the
// larger of the two values. When only one of the two results is used later, only that one is
// computed (kMin keeps a, kMax keeps b).
enum CmpKind : std::uint8_t { kSort, kMin, kMax };
struct Cmp {
  std::uint8_t a, b;
  CmpKind kind;
};

// Optimal 5-sorter (9 comparators), applied to each column of the 5x5 window.
inline constexpr Cmp kSort5[] = {{0, 1, kSort}, {2, 3, kSort}, {0, 2, kSort}, {1, 3, kSort}, {1, 2, kSort},
                                 {0, 4, kSort}, {2, 4, kSort}, {1, 2, kSort}, {3, 4, kSort}};

// Median of 25 values whose five columns are already sorted. Wire 5 i + j is rank i of column j.
// Construction: sorting the five rank rows keeps the columns sorted, so value (i, j) then has at
// least (i + 1)(j + 1) values <= it and (5 - i)(5 - j) values >= it. Only 13 positions can hold
// the 13th smallest; 6 values lie surely below them, so the median is the 7th of those 13, taken
// by an odd-even merge sorter. Comparators that never swap on column-sorted input were removed
// and those whose results are never read were pruned; the network was checked on all 6^5
// column-sorted 0/1 inputs, which by the 0-1 principle covers every input. Result: wire 21.
inline constexpr Cmp kMedianOfSortedColumns25[] = {
    {0, 1, kSort},   {2, 3, kSort},   {0, 2, kSort},   {1, 3, kSort},   {1, 2, kMax},    {0, 4, kMax},
    {2, 4, kMax},    {3, 4, kSort},   {5, 6, kSort},   {7, 8, kSort},   {5, 7, kSort},   {6, 8, kSort},
    {6, 7, kSort},   {5, 9, kMax},    {7, 9, kSort},   {6, 7, kMax},    {8, 9, kSort},   {10, 11, kSort},
    {12, 13, kSort}, {10, 12, kSort}, {11, 13, kSort}, {11, 12, kSort}, {10, 14, kMax},  {12, 14, kSort},
    {11, 12, kSort}, {13, 14, kMin},  {15, 16, kSort}, {17, 18, kSort}, {15, 17, kSort}, {16, 18, kMin},
    {16, 17, kSort}, {15, 19, kSort}, {17, 19, kMin},  {16, 17, kSort}, {20, 21, kSort}, {22, 23, kSort},
    {20, 22, kSort}, {21, 23, kMin},  {21, 22, kSort}, {20, 24, kSort}, {22, 24, kMin},  {21, 22, kMin},
    {11, 3, kSort},  {7, 15, kSort},  {20, 13, kSort}, {21, 4, kSort},  {16, 12, kSort}, {11, 7, kMax},
    {3, 15, kSort},  {20, 21, kSort}, {13, 4, kMin},   {8, 16, kSort},  {9, 12, kMin},   {3, 7, kMax},
    {13, 21, kSort}, {9, 16, kSort},  {7, 20, kMax},   {15, 13, kSort}, {16, 17, kMin},  {15, 20, kSort},
    {13, 21, kSort}, {20, 8, kMax},   {13, 9, kMin},   {21, 16, kMin},  {15, 13, kMax},  {21, 8, kMin},
    {13, 21, kMax}};
inline constexpr int kMedian25Result = 21;

}  // namespace mctstereo::detail::cpu
#endif  // MCTSTEREO_CPU_MEDIAN_NETWORKS

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using MedianTag = hn::ScalableTag<std::int16_t>;
using MedianVec = hn::Vec<MedianTag>;

// The comparator's fields are template arguments one by one (not a reference to the array
// element, which Clang 14 does not take as a template argument).
template <int a, int b, CmpKind kind>
HWY_INLINE void Apply(VecSlot<MedianTag>* v) {
  if constexpr (kind == kSort) {
    const MedianVec lo = hn::Min(v[a], v[b]);
    v[b] = hn::Max(v[a], v[b]);
    v[a] = lo;
  } else if constexpr (kind == kMin) {
    v[a] = hn::Min(v[a], v[b]);
  } else {
    v[b] = hn::Max(v[a], v[b]);
  }
}

// Expands a network into straight-line code: every wire index is a constant, so the compiler
// keeps all wires in registers.
template <const auto& kNet, std::size_t... I>
HWY_INLINE void ApplyNetwork(VecSlot<MedianTag>* v, std::index_sequence<I...>) {
  (Apply<kNet[I].a, kNet[I].b, kNet[I].kind>(v), ...);
}
template <const auto& kNet>
HWY_INLINE void ApplyNetwork(VecSlot<MedianTag>* v) {
  ApplyNetwork<kNet>(v, std::make_index_sequence<std::size(kNet)>());
}

// Median of each lane's 5x5 window: sort the five columns, then the network above.
HWY_INLINE MedianVec Median5x5(const std::int16_t* const* win) {
  const MedianTag d;
  VecSlot<MedianTag> v[25];
  for (int j = 0; j < 5; ++j) {
    VecSlot<MedianTag> col[5];
    for (int i = 0; i < 5; ++i) col[i] = hn::LoadU(d, win[i] + j);
    ApplyNetwork<kSort5>(col);
    for (int i = 0; i < 5; ++i) v[5 * i + j] = col[i];
  }
  ApplyNetwork<kMedianOfSortedColumns25>(v);
  return v[kMedian25Result];
}

// The window rows of a vector of outputs at x0 that touches a border, copied with clamped columns
// into border[j] (n + 2 R entries). Where the row is at least n + R wide the window leaves it on
// one side only (x0 = 0, or x0 = w - n): one copy of n + R entries, a constant size on
// fixed-width targets, and R repeated edge values. The general loop with a clamped index per
// entry made a border vector cost several interior ones (about half of the 3x3 median's time at
// 640 x 480).
template <int K>
HWY_INLINE void BorderWindow(const std::int16_t* const* rows, int w, int x0, int n, std::int16_t (*border)[hn::MaxLanes(MedianTag()) + 2 * (K / 2)]) {
  constexpr int R = K / 2;
  if (w >= n + R && (x0 == 0 || x0 == w - n)) {
    for (int j = 0; j < K; ++j) {
      if (x0 == 0) {
        std::memcpy(border[j] + R, rows[j], sizeof(std::int16_t) * (n + R));
        for (int i = 0; i < R; ++i) border[j][i] = rows[j][0];
      } else {
        std::memcpy(border[j], rows[j] + x0 - R, sizeof(std::int16_t) * (n + R));
        for (int i = n + R; i < n + 2 * R; ++i) border[j][i] = rows[j][w - 1];
      }
    }
    return;
  }
  for (int j = 0; j < K; ++j) copy_clamped(rows[j], w, x0 - R, n + 2 * R, border[j]);
}

// The 3x3 median of one row. Sorting the three values of each window column (lo <= mid <= hi)
// gives the classic exact shortcut: median = med3(max of the lows, med3 of the mids, min of the
// highs). Each column is sorted once: a pass sorts the columns of a block of the row into three
// rows of lows, middles and highs (kept in L1), and a second pass reads each output's three
// columns from them at shifted offsets, 6 + 12 vector operations per output vector where sorting
// the three columns of every output vector took 18 + 12 (0.072 -> 0.057 ms for a 640 x 480 map
// on 1 thread). Two passes rather than one, so that the unaligned loads do not read stores still
// in flight (store-to-load forwarding stalls).
constexpr int kMedian3Block = 256;  // output columns per block (the last takes the rest, < 256 + lanes)

HWY_INLINE void Median3Row(const std::int16_t* const* rows, int w, std::int16_t* out) {
  const MedianTag d;
  const int n = static_cast<int>(hn::Lanes(d));
  constexpr std::size_t kMaxLanes = hn::MaxLanes(MedianTag());
  constexpr std::size_t kBuffer = kMedian3Block + 2 * kMaxLanes + 4;
  // Buffer entry i holds the sorted column xb - 1 + i; columns -1 and w are copies of 0 and w - 1.
  HWY_ALIGN std::int16_t lo[kBuffer], mid[kBuffer], hi[kBuffer];
  for (int xb = 0; xb < w;) {
    const int xe = w - xb < kMedian3Block + n ? w : xb + kMedian3Block;
    // Loads run up to n - 1 columns past the last needed one: inside the rows' 64-byte slack
    // (n <= 32), and the entries they make past column w are overwritten or feed unused lanes.
    for (int c = std::max(xb - 1, 0); c < std::min(xe + 1, w); c += n) {
      const MedianVec a = hn::LoadU(d, rows[0] + c), b = hn::LoadU(d, rows[1] + c), e = hn::LoadU(d, rows[2] + c);
      const MedianVec ab = hn::Min(a, b), bmax = hn::Max(a, b);
      const MedianVec t = hn::Max(ab, e);
      const int i = c - (xb - 1);
      hn::StoreU(hn::Min(ab, e), d, lo + i);
      hn::StoreU(hn::Min(bmax, t), d, mid + i);
      hn::StoreU(hn::Max(bmax, t), d, hi + i);
    }
    if (xb == 0) lo[0] = lo[1], mid[0] = mid[1], hi[0] = hi[1];
    if (xe == w) {
      const int i = w - (xb - 1);
      lo[i] = lo[i - 1], mid[i] = mid[i - 1], hi[i] = hi[i - 1];
    }
    const auto median_at = [&](int x) {  // output x: buffer entries x - xb .. x - xb + 2
      const int i = x - xb;
      const auto med3 = [](MedianVec a, MedianVec b, MedianVec c) {
        return hn::Max(hn::Min(a, b), hn::Min(hn::Max(a, b), c));
      };
      const MedianVec max_lo = hn::Max(hn::Max(hn::LoadU(d, lo + i), hn::LoadU(d, lo + i + 1)), hn::LoadU(d, lo + i + 2));
      const MedianVec min_hi = hn::Min(hn::Min(hn::LoadU(d, hi + i), hn::LoadU(d, hi + i + 1)), hn::LoadU(d, hi + i + 2));
      return med3(max_lo, med3(hn::LoadU(d, mid + i), hn::LoadU(d, mid + i + 1), hn::LoadU(d, mid + i + 2)), min_hi);
    };
    if (xe - xb >= n) {
      // Whole vectors; the last one overlaps the one before rather than running past the block
      // (its overlapped pixels get the same medians again).
      for (int x = xb; x < xe; x += n) {
        const int xo = std::min(x, xe - n);
        hn::StoreU(median_at(xo), d, out + xo);
      }
    } else {  // a row narrower than a vector
      HWY_ALIGN std::int16_t tail[kMaxLanes];
      hn::Store(median_at(xb), d, tail);
      std::memcpy(out + xb, tail, sizeof(std::int16_t) * (xe - xb));
    }
    xb = xe;
  }
}

// The 5x5 median of one row: the interior vectors read the rows in place, in a loop of their own;
// the vectors at the borders (or every vector of a narrow image) read a copy of their window. The
// last vector overlaps the one before rather than running past the row (its overlapped pixels
// get the same medians again); a row narrower than a vector goes through a stack buffer.
HWY_INLINE void Median5Row(const std::int16_t* const* rows, int w, std::int16_t* out) {
  constexpr int K = 5, R = K / 2;
  const MedianTag d;
  const int n = static_cast<int>(hn::Lanes(d));
  constexpr std::size_t kMaxLanes = hn::MaxLanes(MedianTag());
  const auto median = [](const std::int16_t* const* win) { return Median5x5(win); };
  const int first = (R + n - 1) / n * n;  // the first vector x0 >= R
  int x0 = first;
  for (; x0 + n + R <= w; x0 += n) {
    const std::int16_t* win[K];
    for (int j = 0; j < K; ++j) win[j] = rows[j] + x0 - R;
    hn::StoreU(median(win), d, out + x0);
  }
  HWY_ALIGN std::int16_t border[K][kMaxLanes + 2 * R];
  const std::int16_t* win[K];
  for (int j = 0; j < K; ++j) win[j] = border[j];
  const auto border_vector = [&](int x) {
    if (w >= n) {
      const int bx = std::min(x, w - n);
      BorderWindow<K>(rows, w, bx, n, border);
      hn::StoreU(median(win), d, out + bx);
    } else {
      HWY_ALIGN std::int16_t tail[kMaxLanes];
      BorderWindow<K>(rows, w, 0, n, border);
      hn::Store(median(win), d, tail);
      std::memcpy(out, tail, sizeof(std::int16_t) * w);
    }
  };
  for (int x = 0; x < std::min(first, w); x += n) border_vector(x);
  for (; x0 < w; x0 += n) border_vector(x0);
}

// The k x k median of one row (k = 3, 5): rows[j] is the window's row j (image row y + j - k / 2,
// clamped), each w wide with the planes' 64 bytes of slack; out: w entries.
template <int K>
HWY_INLINE void MedianRow(const std::int16_t* const* rows, int w, std::int16_t* out) {
  static_assert(K == 3 || K == 5);
  if constexpr (K == 3) Median3Row(rows, w, out);
  else Median5Row(rows, w, out);
}

// Row y of the k x k median of a whole map (k = 3, 5; rows clamped at the borders) into out.
HWY_INLINE void MedianOfMapRow(const Plane<std::int16_t>& map, int k, int y, std::int16_t* out) {
  const int h = map.height(), w = map.width();
  const std::int16_t* rows[5];
  for (int j = 0; j < k; ++j) rows[j] = map.row(clamp_index(y + j - k / 2, h));
  if (k == 3) MedianRow<3>(rows, w, out);
  else MedianRow<5>(rows, w, out);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#endif  // per-target include guard
