// Band SGM path aggregation with Highway SIMD over a pixel's candidates, OpenMP over the lines of
// a path (rows, columns or diagonals: independent of each other, handed out dynamically so that
// a descheduled thread does not hold the others up).
//
// A path step reads the predecessor's values at the same disparities: with s = lo(p) - lo(q),
// candidate k of p is candidate k + s of q. The predecessor's values sit in a buffer with
// stride + 2 entries of kSgmInf on each side, so three unaligned loads at k + s - 1, k + s and
// k + s + 1 give L(q, d - 1), L(q, d), L(q, d + 1), out-of-band entries being +inf as the
// reference has them; |s| beyond stride + 1 reads only padding, so s is clamped there.
//
// Exactness with the reference's int arithmetic: every in-band value is below C_max + P2 and every
// sum below paths x (C_max + P2) <= 65534 (validate()), so saturating u16 adds only ever saturate
// on kSgmInf (out-of-band entries), which they keep at kSgmInf. The minimum t of the recursion is
// never below m(q), so t - m(q) does not wrap.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/sgm_aggregate.cpp"
#ifndef HWY_WANT_AVX3_DL
#define HWY_WANT_AVX3_DL
#endif
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include <omp.h>

#include <algorithm>

#include "cpu/parallel.hpp"
#include "cpu/sgm_segments.hpp"
#include "stages.hpp"

#ifndef MCTSTEREO_CPU_SGM_AGGREGATE_ONCE
#define MCTSTEREO_CPU_SGM_AGGREGATE_ONCE
namespace mctstereo::detail::cpu {

// One padded buffer of path values: at least stride + 2 padding entries each side (the reads
// at k + s +- 1 with |s| <= stride + 1), rounded to 32 entries so that the values themselves sit
// on 64-byte boundaries (the buffers are 64-byte aligned; a slot of 32 is one AVX-512 vector),
// and slack.
inline int path_buffer_pad(int stride) { return (stride + 2 + 31) / 32 * 32; }
inline int path_buffer_entries(int stride) { return stride + 2 * path_buffer_pad(stride) + 32; }
// Lines a horizontal path (rows) and a vertical path (columns) walk together, at most. Columns
// take more: each row of a column block is a separate run of memory, and longer runs stream
// better. Rows: 8 interleaved lines hide the latency of a step's minimum as well as 16 did, in
// fewer streams of memory at once (quality at 640 x 480 with 2 threads: 17.8-18.0 against
// 18.4-18.6 ms; 4 lines: 18.6-18.8). A block is one thread's work from start to end, so small
// levels take smaller blocks (block_lines()) to give every thread several.
inline constexpr int kRowBlock = 8;
inline constexpr int kColumnBlock = 32;
inline constexpr int kMaxBlock = std::max(kRowBlock, kColumnBlock);

// Lines per block: the most, halved (down to 4) until the lines make 6 blocks per thread.
inline int block_lines(int most, int lines, int threads) {
  int b = most;
  while (b > 4 && (lines + b - 1) / b < 6 * threads) b /= 2;
  return b;
}

// Per thread: two path buffers per line of a block for sgm_aggregate, five padded u16 rows
// for sgm_select's right view, or for sgm_costs' bands seven int rows of the level's width (the
// coarse row's) and six int16 rows of the width plus 64 (the temporal prior's), each part 64-byte
// aligned.
std::size_t sgm_scratch_bytes(int width, int /*height*/, int stride) {
  const std::size_t w = static_cast<std::size_t>(width);
  const std::size_t bands = (7 * w * sizeof(int) + 63) / 64 * 64 + 6 * ((w + 64 + 31) / 32 * 32) * sizeof(std::int16_t);
  return std::max({2 * kMaxBlock * static_cast<std::size_t>(path_buffer_entries(stride)) * sizeof(std::uint16_t),
                   5 * (w + 2 * right_row_pad(stride)) * sizeof(std::uint16_t), bands});
}

// The first pixel of line i of a path with step (dx, dy).
struct PathLines {
  int w, h, dx, dy;
  int count() const {
    if (dy == 0) return h;
    if (dx == 0) return w;
    return w + h - 1;
  }
  void start(int i, int& x, int& y) const {
    const int x_edge = dx > 0 ? 0 : w - 1, y_edge = dy > 0 ? 0 : h - 1;
    if (dy == 0) {
      x = x_edge;
      y = i;
    } else if (dx == 0 || i < w) {
      x = i;
      y = y_edge;
    } else {
      x = x_edge;
      y = dy > 0 ? i - w + 1 : h - 2 - (i - w);
    }
  }
};

}  // namespace mctstereo::detail::cpu
#endif

#include "cpu/min_lanes-inl.h"

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

// Slots of 16 entries take vectors of 16 lanes (one on AVX2 and AVX-512, two on 128-bit targets);
// wider slots WideTagU16 where WideSlots() says so (cpu/min_lanes-inl.h).
using DU16 = MinTagU16;

// The state a path carries from one pixel to the next on its line.
struct PathState {
  std::uint16_t* prev;  // the predecessor's values (padded), then the buffer of the next values
  std::uint16_t* cur;   // (slots of one vector: the values are replaced in prev, cur is unused)
  // m_prev == kSgmInf (all of prev +inf): the path (re)starts, L = C.
  int m_prev = kSgmInf, lo_prev = 0, gray_prev = 0;
};

// The planes of one row that a step reads and writes, looked up once per row: through the
// planes, every pixel would reload their data pointers and strides (the stores into the sums
// may alias them as far as the compiler knows) and multiply again.
struct RowView {
  const std::uint16_t* cost;  // pixel 0's slot: 16-bit costs, or
  const std::uint8_t* cost8;  // byte costs (SgmVolume::use_byte_costs())
  std::uint16_t* sum;
  const std::int16_t* lo;
  const std::uint8_t* gray;
};

RowView row_view(const Plane<std::uint8_t>& gray, SgmVolume& v, int y) {
  return v.cost8 ? RowView{nullptr, v.cost8_at(0, y), v.sum_at(0, y), v.lo.row(y), gray.row(y)}
                 : RowView{v.cost_at(0, y), nullptr, v.sum_at(0, y), v.lo.row(y), gray.row(y)};
}

// What every step of a path shares.
struct PathConstants {
  int stride, pad;
  std::uint16_t p1;
  const int* p2_of_diff;  // P2' of every gray difference
};

// Costs at entry `at` of the row's slots in u16 lanes: byte costs widened, their kSgmInf8 made
// kSgmInf again.
template <bool kBytes, class D>
HWY_INLINE hn::Vec<D> LoadCosts(D d, const RowView& r, std::size_t at) {
  if constexpr (kBytes) {
    const hn::Rebind<std::uint8_t, D> d8;
    const auto c = hn::PromoteTo(d, hn::LoadU(d8, r.cost8 + at));
    return hn::IfThenElse(hn::Eq(c, hn::Set(d, kSgmInf8)), hn::Set(d, kSgmInf), c);
  } else {
    return hn::LoadU(d, r.cost + at);
  }
}

// One step of a path: the values of pixel x of row r from its predecessor's, into the sums as
// kSums (SgmSumMode) says. kVecs = stride / lanes when known at compile time (0: any); kBytes: the volume's
// costs are bytes.
template <class D, int kSums, int kVecs, bool kBytes>
HWY_INLINE void PathStep(const RowView& r, int x, const PathConstants& c, PathState& st) {
  const D d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int stride = kVecs > 0 ? kVecs * n : c.stride;
  const std::size_t slot = static_cast<std::size_t>(x) * stride;
  std::uint16_t* sum = r.sum + slot;
  // A slot of one vector is read whole before it is written: its values replace the predecessor's
  // in place, and the buffers need no swap.
  std::uint16_t* l = (kVecs == 1 ? st.prev : st.cur) + c.pad;
  const int lo = r.lo[x], g = r.gray[x];
  auto vmin = hn::Set(d, kSgmInf);
  // The values go to the buffer (for the next step) and into the sums in the same pass.
  const auto emit = [&](int k, decltype(vmin) value) {
    hn::Store(value, d, l + k);
    if constexpr (kSums == kWriteSums) hn::StoreU(value, d, sum + k);
    if constexpr (kSums == kAddSums) hn::StoreU(hn::SaturatedAdd(hn::LoadU(d, sum + k), value), d, sum + k);
    vmin = hn::Min(vmin, value);
  };
  // Where the path starts (or its predecessor had no candidate) m(q) = +inf and every value of q
  // is +inf: the jump saturates to +inf too, so t = +inf, t - m = 0 and L = C, with no branch.
  const int limit = stride + 1;
  int s = lo - st.lo_prev;
  if (static_cast<unsigned>(s + limit) > static_cast<unsigned>(2 * limit)) s = s < 0 ? -limit : limit;
  const std::uint16_t* q = st.prev + c.pad + s;
  const auto p1 = hn::Set(d, c.p1);
  const auto m = hn::Set(d, static_cast<std::uint16_t>(st.m_prev));
  const int diff = g > st.gray_prev ? g - st.gray_prev : st.gray_prev - g;
  const auto jump = hn::SaturatedAdd(m, hn::Set(d, static_cast<std::uint16_t>(c.p2_of_diff[diff])));
  for (int k = 0; k < stride; k += n) {
    const auto same = hn::LoadU(d, q + k);
    const auto below = hn::SaturatedAdd(hn::LoadU(d, q + k - 1), p1);
    const auto above = hn::SaturatedAdd(hn::LoadU(d, q + k + 1), p1);
    const auto t = hn::Min(hn::Min(same, jump), hn::Min(below, above));
    emit(k, hn::SaturatedAdd(LoadCosts<kBytes>(d, r, slot + k), hn::Sub(t, m)));
  }
  st.m_prev = MinLaneOf(d, vmin);
  st.lo_prev = lo;
  st.gray_prev = g;
  if constexpr (kVecs != 1) std::swap(st.prev, st.cur);
}

PathState fresh_state(std::uint16_t* buffers, int entries) {
  std::fill_n(buffers, 2 * entries, kSgmInf);
  return PathState{buffers, buffers + entries};
}

// The walks below take the constants by value: a copy of their own that no store into the path
// buffers or sums can alias, so that the compiler keeps them in registers across the steps
// instead of reloading them after every store.

// A path along one line (a diagonal), pixel after pixel.
template <class D, int kVecs, bool kBytes>
void PathLine(const Plane<std::uint8_t>& gray, PathConstants c, int x, int y, int dx, int dy,
              std::uint16_t* buffers, SgmVolume& v) {
  PathState st = fresh_state(buffers, path_buffer_entries(v.stride));
  for (; x >= 0 && x < v.width && y >= 0 && y < v.height; x += dx, y += dy)
    PathStep<D, kAddSums, kVecs, kBytes>(row_view(gray, v, y), x, c, st);
}

// A horizontal path over a block of rows at once, column after column. A step depends on the one
// before through m(q) (a reduction over the lanes), so one line alone is latency-bound;
// interleaving independent lines fills that time.
template <class D, int kSums, int kVecs, bool kBytes>
void PathRows(const Plane<std::uint8_t>& gray, PathConstants c, int y0, int block, int last, int dx,
              std::uint16_t* buffers, SgmVolume& v) {
  const int entries = path_buffer_entries(v.stride);
  const int rows = std::min(y0 + block, last) - y0;
  PathState st[kRowBlock];
  RowView view[kRowBlock];
  for (int j = 0; j < rows; ++j) {
    st[j] = fresh_state(buffers + 2 * entries * j, entries);
    view[j] = row_view(gray, v, y0 + j);
  }
  for (int i = 0; i < v.width; ++i) {
    const int x = dx > 0 ? i : v.width - 1 - i;
    for (int j = 0; j < rows; ++j) PathStep<D, kSums, kVecs, kBytes>(view[j], x, c, st[j]);
  }
}

// A vertical path over a block of columns at once, row after row: the columns' values stay in
// their own buffers, and the volume is read along rows (one column at a time would jump a whole
// row of slots per step, a cache and TLB miss each: measured 8x slower at 640 x 480). Each row
// of a block is a short run in a new page, where the hardware prefetchers do not follow: the
// block's slots a few rows ahead are prefetched. Rows [first, last), from the columns' values in
// `from` (or afresh), leaving them in `to` (when not null).
template <class D, int kSums, int kVecs, bool kBytes>
void PathColumns(const Plane<std::uint8_t>& gray, PathConstants c, int x0, int block, int dy, int first,
                 int last, const SgmRowState* from, SgmRowState* to, std::uint16_t* buffers, SgmVolume& v) {
  const int entries = path_buffer_entries(v.stride);
  const int x1 = std::min(x0 + block, v.width);
  constexpr int kAhead = 4;
  PathState st[kColumnBlock];
  for (int x = x0; x < x1; ++x) {
    PathState& s = st[x - x0];
    s = fresh_state(buffers + 2 * entries * (x - x0), entries);
    if (from == nullptr || from->y < 0) continue;
    std::copy_n(from->values + static_cast<std::size_t>(x) * v.stride, v.stride, s.prev + c.pad);
    s.m_prev = from->m[x];
    s.lo_prev = v.lo.at(x, from->y);
    s.gray_prev = gray.at(x, from->y);
  }
  const int sum_bytes = (x1 - x0) * v.stride * static_cast<int>(sizeof(std::uint16_t));
  const int cost_bytes = kBytes ? sum_bytes / 2 : sum_bytes;
  for (int i = 0; i < last - first; ++i) {
    const int y = dy > 0 ? first + i : last - 1 - i;
    const int ahead = y + kAhead * dy;
    if (ahead >= first && ahead < last) {
      const char* cost =
          kBytes ? reinterpret_cast<const char*>(v.cost8_at(x0, ahead)) : reinterpret_cast<const char*>(v.cost_at(x0, ahead));
      for (int b = 0; b < cost_bytes; b += 64) hwy::Prefetch(cost + b);
      if constexpr (kSums != kNoSums) {
        const char* sum = reinterpret_cast<const char*>(v.sum_at(x0, ahead));
        for (int b = 0; b < sum_bytes; b += 64) hwy::Prefetch(sum + b);
      }
    }
    const RowView view = row_view(gray, v, y);
    for (int x = x0; x < x1; ++x) PathStep<D, kSums, kVecs, kBytes>(view, x, c, st[x - x0]);
  }
  if (to == nullptr) return;
  for (int x = x0; x < x1; ++x) {
    std::copy_n(st[x - x0].prev + c.pad, v.stride, to->values + static_cast<std::size_t>(x) * v.stride);
    to->m[x] = static_cast<std::uint16_t>(st[x - x0].m_prev);
  }
}

// The thread's slice of the scratch: its path buffers.
inline std::uint16_t* thread_buffers(SgmScratch& scratch) {
  if (t_pool && t_pool->size() > scratch.threads) std::abort();  // a scratch slice per thread
  return reinterpret_cast<std::uint16_t*>(scratch.data.get() + thread_slot() * scratch.bytes_per_thread);
}

// Both horizontal paths of the blocks of rows in [first, last), the first of them writing the
// sums when kFirstPath.
template <class D, bool kFirstPath, int kVecs, bool kBytes>
void HorizontalPaths(const Plane<std::uint8_t>& gray, const PathConstants& c, SgmScratch& scratch, int first, int last,
                     SgmVolume& v) {
  const int row_block = block_lines(kRowBlock, last - first, scratch.threads);
  parallel_for(
      (last - first + row_block - 1) / row_block, 1,
      [&](int b0, int b1) {
        for (int b = b0; b < b1; ++b) {
          const int y0 = first + b * row_block;
          PathRows<D, kFirstPath ? kWriteSums : kAddSums, kVecs, kBytes>(gray, c, y0, row_block, last, +1,
                                                                         thread_buffers(scratch), v);
          PathRows<D, kAddSums, kVecs, kBytes>(gray, c, y0, row_block, last, -1, thread_buffers(scratch), v);
        }
      },
      scratch.threads);
}

template <class D, int kVecs, bool kBytes>
void AggregateAll(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, const PathConstants& c,
                  SgmScratch& scratch, SgmVolume& v) {
  const int column_block = block_lines(kColumnBlock, v.width, scratch.threads);
  const int column_blocks = (v.width + column_block - 1) / column_block;
  // Both horizontal paths of a block of rows, then both vertical ones of a block of columns:
  // the second path of each pair finds the block's costs and sums still in the L2 cache (a
  // block of 8 lines of 640 pixels x 32 candidates is 640 KiB of both), so each pair streams
  // the volume from memory once instead of twice. Each pass ends before the next starts: the
  // passes add into the same sums.
  HorizontalPaths<D, true, kVecs, kBytes>(gray, c, scratch, 0, v.height, v);
  parallel_for(
      column_blocks, 1,
      [&](int b0, int b1) {
        for (int b = b0; b < b1; ++b)
          for (int dy : {+1, -1})
            PathColumns<D, kAddSums, kVecs, kBytes>(gray, c, b * column_block, column_block, dy, 0, v.height, nullptr,
                                                    nullptr, thread_buffers(scratch), v);
      },
      scratch.threads);
  // The diagonals (8 paths), line by line.
  for (int r = 4; r < config.paths; ++r) {
    const PathLines lines{v.width, v.height, kSgmSteps[r][0], kSgmSteps[r][1]};
    parallel_for(
        lines.count(), 4,
        [&](int i0, int i1) {
          for (int i = i0; i < i1; ++i) {
            int x, y;
            lines.start(i, x, y);
            PathLine<D, kVecs, kBytes>(gray, c, x, y, lines.dx, lines.dy, thread_buffers(scratch), v);
          }
        },
        scratch.threads);
  }
}

// One vertical path over rows [first, last) of every column (sgm_vertical_rows()).
template <class D, int kVecs, bool kBytes>
void VerticalRows(const Plane<std::uint8_t>& gray, const PathConstants& c, SgmScratch& scratch, int first, int last,
                  int dy, int sums, const SgmRowState& from, SgmRowState* to, SgmVolume& v) {
  const int column_block = block_lines(kColumnBlock, v.width, scratch.threads);
  parallel_for(
      (v.width + column_block - 1) / column_block, 1,
      [&](int b0, int b1) {
        for (int b = b0; b < b1; ++b) {
          const int x0 = b * column_block;
          std::uint16_t* buffers = thread_buffers(scratch);
          if (sums == kWriteSums)
            PathColumns<D, kWriteSums, kVecs, kBytes>(gray, c, x0, column_block, dy, first, last, &from, to, buffers, v);
          else if (sums == kAddSums)
            PathColumns<D, kAddSums, kVecs, kBytes>(gray, c, x0, column_block, dy, first, last, &from, to, buffers, v);
          else
            PathColumns<D, kNoSums, kVecs, kBytes>(gray, c, x0, column_block, dy, first, last, &from, to, buffers, v);
        }
      },
      scratch.threads);
  if (to != nullptr) to->y = dy > 0 ? last - 1 : first;
}

// Calls f.template operator()<D, kVecs, kBytes>() with the slot types of the volume: slots of one
// vector (16 candidates; 32 on AVX-512 and wide SVE) and of two 16-lane vectors (32 candidates on
// AVX2) unroll.
template <bool kBytes, class F>
void WithSlotTypes(const SgmVolume& v, F&& f) {
  if (WideSlots(v.stride)) {
    if (v.stride == static_cast<int>(hn::Lanes(WideTagU16())))
      f.template operator()<WideTagU16, 1, kBytes>();
    else
      f.template operator()<WideTagU16, 0, kBytes>();
    return;
  }
  const int vecs = v.stride / static_cast<int>(hn::Lanes(DU16()));
  if (vecs == 1) f.template operator()<DU16, 1, kBytes>();
  else if (vecs == 2) f.template operator()<DU16, 2, kBytes>();
  else f.template operator()<DU16, 0, kBytes>();
}

template <class F>
void WithVolumeTypes(const SgmVolume& v, F&& f) {
  if (v.cost8)
    WithSlotTypes<true>(v, f);
  else
    WithSlotTypes<false>(v, f);
}

// The constants of every step; p2_of_diff: 256 entries to fill, P2' of every gray difference (one
// look-up per step instead of a division).
PathConstants path_constants(const SgmPathConfig& config, const SgmVolume& v, int* p2_of_diff) {
  for (int diff = 0; diff < 256; ++diff) p2_of_diff[diff] = sgm_p2_at(config, diff, 0);
  return PathConstants{v.stride, path_buffer_pad(v.stride), static_cast<std::uint16_t>(config.p1), p2_of_diff};
}

void SgmAggregate(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch, SgmVolume& v) {
  int p2_of_diff[256];
  const PathConstants c = path_constants(config, v, p2_of_diff);
  WithVolumeTypes(v, [&]<class D, int kVecs, bool kBytes>() { AggregateAll<D, kVecs, kBytes>(gray, config, c, scratch, v); });
}

void SgmVerticalRows(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch, SgmVolume& v,
                     int first, int last, int dy, int sums, const SgmRowState& from, SgmRowState* to) {
  int p2_of_diff[256];
  const PathConstants c = path_constants(config, v, p2_of_diff);
  WithVolumeTypes(v, [&]<class D, int kVecs, bool kBytes>() {
    VerticalRows<D, kVecs, kBytes>(gray, c, scratch, first, last, dy, sums, from, to, v);
  });
}

void SgmHorizontalRows(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                       SgmVolume& v, int first, int last) {
  int p2_of_diff[256];
  const PathConstants c = path_constants(config, v, p2_of_diff);
  WithVolumeTypes(v, [&]<class D, int kVecs, bool kBytes>() {
    HorizontalPaths<D, false, kVecs, kBytes>(gray, c, scratch, first, last, v);
  });
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(SgmAggregate);
HWY_EXPORT(SgmVerticalRows);
HWY_EXPORT(SgmHorizontalRows);
void sgm_vertical_rows(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                       SgmVolume& volume, int first, int last, int dy, SgmSumMode sums, const SgmRowState& from,
                       SgmRowState* to) {
  HWY_DYNAMIC_DISPATCH(SgmVerticalRows)(gray, config, scratch, volume, first, last, dy, sums, from, to);
}
void sgm_horizontal_rows(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                         SgmVolume& volume, int first, int last) {
  HWY_DYNAMIC_DISPATCH(SgmHorizontalRows)(gray, config, scratch, volume, first, last);
}
void sgm_aggregate(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                   SgmVolume& volume) {
  HWY_DYNAMIC_DISPATCH(SgmAggregate)(gray, config, scratch, volume);
}
}  // namespace mctstereo::detail::cpu
#endif
