// The finest level's refinement of the left map in strips of rows: per strip, the median of both
// raw maps, the LR check and the fill of each row, then the median after filling, while the
// strip's rows are in the L1/L2 cache. As separate stages, each of the five passes read and wrote
// whole maps (at 640 x 480 four maps of 600 KB), and each ended in a wait for every thread.
//
// A strip of kStripRows output rows needs the filled rows one (post-median 3) or two (5) above
// and below it: each strip makes those halo rows itself (the strips above and below make them
// too), so the strips are independent and any thread may take any of them. The medians read the
// raw maps, which no strip writes; the LR check of a row reads that row of both median maps only
// (with the check on the grid, the right view's partners of that row: grid_partner_row-inl.h).
// Each row goes through the stages' own row functions, so the result is theirs bit for bit.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "cpu/refine_left_map.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include "cpu/fill_row-inl.h"
#include "cpu/grid_partner_row-inl.h"
#include "cpu/lr_check_row-inl.h"
#include "cpu/median_row-inl.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "cpu/match_tiles.hpp"
#include "cpu/parallel.hpp"
#include "stages.hpp"

#ifndef MCTSTEREO_CPU_REFINE_LEFT_MAP_LAYOUT
#define MCTSTEREO_CPU_REFINE_LEFT_MAP_LAYOUT
namespace mctstereo::detail::cpu {
namespace {

// 16 rows: the halo of a 3x3 post-median makes 2 rows in 16 twice (12 %); strips of 32 made it 6 %
// but gave the threads of a loaded CPU half as many pieces to share.
constexpr int kStripRows = 16;
constexpr int kMaxHalo = 2;  // post-median 5
// Rows of a thread's scratch: a strip's filled rows with their halo, and one median row per view
// (with the LR check on the grid, the right one holds the partners); then the grid rows.
constexpr int kScratchRows = kStripRows + 2 * kMaxHalo + 2;

std::ptrdiff_t row_stride(int width) { return Plane<std::int16_t>::stride_for(width, 0); }
std::size_t scratch_bytes(int width) {
  return static_cast<std::size_t>(kScratchRows * row_stride(width)) * sizeof(std::int16_t) + grid_rows_bytes(width);
}

}  // namespace
}  // namespace mctstereo::detail::cpu
#endif  // MCTSTEREO_CPU_REFINE_LEFT_MAP_LAYOUT

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {

// The right view's row that row y of the left map is checked against: its median, or with the
// check on the grid (config.grid) the partners, which rows 2j and 2j + 1 share (made once for both
// when y - 1 came just before: grid_row remembers the grid row that `partners` holds).
HWY_INLINE const std::int16_t* RightRowFor(const Plane<std::int16_t>& right, const LeftMapRefinement& config, int y,
                                           std::int16_t* grid_rows, std::int16_t* partners, int& grid_row) {
  if (config.grid) {
    if (grid_row != y / 2) {
      GridPartnerRow(right, config.median_size, y / 2, grid_rows, grid_row_stride(right.width()), partners);
      grid_row = y / 2;
    }
    return partners;
  }
  if (config.median_size == 0) return right.row(y);
  MedianOfMapRow(right, config.median_size, y, partners);
  return partners;
}

// The filled left row y (median, LR check, fill) into `row`.
HWY_INLINE void FilledRow(const Plane<std::int16_t>& left, const Plane<std::int16_t>& right,
                          const LeftMapRefinement& config, int y, std::int16_t* median_left,
                          std::int16_t* median_right, std::int16_t* grid_rows, int& grid_row, std::int16_t* ext,
                          std::int16_t* row) {
  const std::int16_t* l = left.row(y);
  const std::int16_t* r = RightRowFor(right, config, y, grid_rows, median_right, grid_row);
  if (config.median_size > 0) {
    MedianOfMapRow(left, config.median_size, y, median_left);
    l = median_left;
  }
  LrCheckRow(l, r, left.width(), -1, config.threshold_q4, row, ext);
  if (config.fill != FillMode::None) FillRow(row, left.width(), config.fill);
}

void RefineLeftMap(const Plane<std::int16_t>& left, const Plane<std::int16_t>& right, const LeftMapRefinement& config,
                   MatchScratch& scratch, Plane<std::int16_t>& out) {
  const int w = left.width(), h = left.height();
  const int halo = config.post_median_size / 2;
  const std::ptrdiff_t stride = row_stride(w);
  // Each thread's slice starts at the next 64-byte boundary and holds kScratchRows rows and the
  // grid rows: less is a driver bug, not an input.
  if (aligned_slice_bytes(scratch) < scratch_bytes(w)) std::abort();
  if (t_pool && t_pool->size() > scratch.threads) std::abort();  // a scratch slice per thread
  const int strips = (h + kStripRows - 1) / kStripRows;
  parallel_for(
      strips, 1,
      [&](int s0, int s1) {
        std::int16_t* base = reinterpret_cast<std::int16_t*>(aligned_slice(scratch, thread_slot()));
        std::int16_t* median_left = base + (kScratchRows - 2) * stride;
        std::int16_t* median_right = base + (kScratchRows - 1) * stride;
        std::int16_t* grid_rows = base + kScratchRows * stride;
        int grid_row = -1;
        HWY_ALIGN std::int16_t ext[kLrExtEntries];
        LrExtInit(ext);
        for (int s = s0; s < s1; ++s) {
          const int y0 = s * kStripRows, y1 = std::min(h, y0 + kStripRows);
          const int a0 = std::max(0, y0 - halo), a1 = std::min(h, y1 + halo);  // rows filled
          const auto filled = [&](int y) { return base + (y - a0) * stride; };
          for (int y = a0; y < a1; ++y) FilledRow(left, right, config, y, median_left, median_right, grid_rows, grid_row, ext, filled(y));
          for (int y = y0; y < y1; ++y) {
            if (halo == 0) {
              std::memcpy(out.row(y), filled(y), sizeof(std::int16_t) * w);
              continue;
            }
            const std::int16_t* rows[5];
            for (int j = 0; j < 2 * halo + 1; ++j) rows[j] = filled(clamp_index(y + j - halo, h));
            if (halo == 1) MedianRow<3>(rows, w, out.row(y));
            else MedianRow<5>(rows, w, out.row(y));
          }
        }
      },
      scratch.threads);
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(RefineLeftMap);

void refine_left_map(Plane<std::int16_t>& left, Plane<std::int16_t>& right, const LeftMapRefinement& config,
                     MatchScratch& scratch, Plane<std::int16_t>& /*spare*/, Plane<std::int16_t>& out) {
  if (left.empty()) return;
  HWY_DYNAMIC_DISPATCH(RefineLeftMap)(left, right, config, scratch, out);
}

std::size_t refine_left_map_scratch_bytes(int width) {
  // + kAlignment: the driver's slices start anywhere; each thread aligns its own.
  return scratch_bytes(width) + kAlignment;
}

}  // namespace mctstereo::detail::cpu
#endif  // HWY_ONCE
