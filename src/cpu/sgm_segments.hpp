// Band SGM of a level in segments of rows (cpu backend): the same maps as the costs, paths and
// winners over the whole volume (sgm_costs, sgm_aggregate, sgm_select), with the costs and sums of
// one segment of rows in memory at a time instead of the level's (docs/PIPELINE.md, "Band SGM in
// segments of rows"). 4 paths only: the diagonals cross the columns that split a segment's work.
//
// A first pass walks the bottom-to-top path up the level, segment after segment, and keeps its
// values at the first row of every segment (a checkpoint). A second pass walks down: per segment
// it makes the costs again, runs the bottom-to-top path from the checkpoint below the segment (its
// values become the sums), the top-to-bottom path on from the segment above, the horizontal paths,
// and picks the segment's winners. Every cost is made twice and the bottom-to-top path runs twice.
//
// On 2 threads a whole volume is aggregated in two sweeps instead (sgm_two_sweeps()): each thread
// walks one vertical path over the whole level and both horizontal paths over half of it, so the
// threads share no line of the volume while the other may still write it, and meet only once.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "stages.hpp"

namespace mctstereo::detail::cpu {

/// The values of a vertical path at one row, for every column: where a segment's pass starts or
/// ends. m: the minimum of each column's values (kSgmInf: the path starts afresh below it).
struct SgmRowState {
  std::uint16_t* values = nullptr;  ///< W x stride
  std::uint16_t* m = nullptr;       ///< W
  int y = -1;                       ///< the row they belong to; -1: none (start afresh)
};

/// Segments of `rows` rows of a level h rows high.
inline int sgm_segment_count(int h, int rows) { return (h + rows - 1) / rows; }

/// Bytes of the row states a level w x h with slot stride aggregated in segments of `rows` needs:
/// the top-to-bottom path's and one per segment but the first (the checkpoints); at least two
/// (the two sweeps of a segment on 2 threads take one per path).
inline std::size_t sgm_row_state_bytes(int w, int h, int stride, int rows) {
  return static_cast<std::size_t>(std::max(sgm_segment_count(h, rows), 2)) * w * (stride + 1) * sizeof(std::uint16_t);
}

/// Row state i of storage laid out as sgm_row_state_bytes() counts it.
inline SgmRowState sgm_row_state(std::uint16_t* storage, int w, int stride, int i) {
  std::uint16_t* base = storage + static_cast<std::size_t>(i) * w * (stride + 1);
  return SgmRowState{base, base + static_cast<std::size_t>(w) * stride, -1};
}

/// The costs (and bands) of rows [first, last) of the level, into the volume's storage from its
/// row0, after sgm_mirror_rows() of those rows unless `mirrored` (it has run for them already).
void sgm_costs_rows(const CensusCodes& left, const CensusCodes& right, const Plane<std::int16_t>* coarse,
                    const SgmBandConfig& config, int shd_window, SgmScratch& scratch, SgmVolume& volume, int first,
                    int last, bool mirrored = false);

/// The right view's codes that the cost windows of rows [first, last) read, mirrored into the
/// volume's planes (all of the level's rows, or a window of a segment's rows plus the box's
/// margins from mirror_row0, as the planes' height allows).
void sgm_mirror_rows(const CensusCodes& right, int shd_window, SgmVolume& volume, int first, int last);

/// What a path does with the sums: adds its values, writes them (the first path), or leaves the
/// sums alone (the first pass, which keeps only the path's last row).
enum SgmSumMode : int { kAddSums, kWriteSums, kNoSums };

/// One vertical path (dy = +1 down, -1 up) over rows [first, last) of every column, from `from`
/// (its row next to the rows; y = -1: afresh) to `to` (the last row walked; may be `from`; nullptr:
/// not kept).
void sgm_vertical_rows(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                       SgmVolume& volume, int first, int last, int dy, SgmSumMode sums, const SgmRowState& from,
                       SgmRowState* to);

/// Both horizontal paths of rows [first, last), added into the sums.
void sgm_horizontal_rows(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                         SgmVolume& volume, int first, int last);

/// sgm_select() of rows [first, last).
void sgm_select_rows(const SgmVolume& volume, const SgmSelectConfig& config, SgmScratch& scratch,
                     Plane<std::int16_t>& left, Plane<std::int16_t>* right, Plane<std::uint8_t>* margin, int first,
                     int last);

/// What one level's band SGM in segments reads and writes.
struct SgmSegmentJob {
  const CensusCodes* left = nullptr;
  const CensusCodes* right = nullptr;
  const Plane<std::int16_t>* coarse = nullptr;  ///< the prior (nullptr: the whole range)
  SgmBandConfig band;
  int shd_window = 3;
  const Plane<std::uint8_t>* gray = nullptr;  ///< the left image
  SgmPathConfig paths;                        ///< 4 paths
  SgmSelectConfig select;
  int segment_rows = 0;  ///< rows of the volume's storage (and of the mirrored planes, plus the box's margins)
  std::uint16_t* row_states = nullptr;  ///< sgm_row_state_bytes()
  Plane<std::int16_t>* left_map = nullptr;
  Plane<std::int16_t>* right_map = nullptr;  ///< nullptr: none
  Plane<std::uint8_t>* margin = nullptr;     ///< nullptr: none
};

/// sgm_costs, sgm_aggregate and sgm_select of a level in segments of job.segment_rows rows.
void sgm_segmented(const SgmSegmentJob& job, SgmScratch& scratch, SgmVolume& volume);

/// Whether a level with `paths` paths is aggregated in two sweeps on a stage of `threads` threads
/// (its row states are held whenever that holds). Only on 2: the sweeps are two tasks, and more
/// threads share the passes of sgm_aggregate better.
inline bool sgm_two_sweeps_for(int paths, int threads) { return paths == 4 && threads == 2; }

/// The largest volume (costs and sums, bytes) aggregated in two sweeps. A sweep is one task, and a
/// thread that the OS deschedules in the middle of one holds up the other for as long: on a CPU
/// that another process keeps busy, quality at 640 x 480 (a 28 MiB finest volume) took 27-40 ms
/// a frame on 2 threads in two sweeps against 22-32 ms with sgm_aggregate's short chunks, while
/// balanced (volumes of at most 7 MiB) was faster in two sweeps, loaded or not
/// (docs/PIPELINE.md, "Band SGM in two sweeps").
inline constexpr std::size_t kSweepVolumeLimit = std::size_t{8} << 20;

/// Rows of a block of the sweeps: a block's vertical and horizontal paths (or its vertical path and
/// winners) run one after the other while its costs and sums are still in the L2 cache.
inline constexpr int kSweepRows = 32;

/// Bytes of the two row states of the sweeps (sgm_two_sweeps()) of a level w wide with slot stride.
inline std::size_t sgm_sweep_state_bytes(int w, int stride) {
  return 2 * static_cast<std::size_t>(w) * (stride + 1) * sizeof(std::uint16_t);
}

/// sgm_costs, sgm_aggregate and sgm_select of a whole volume in two sweeps, in blocks of
/// job.segment_rows rows, on two tasks (job.row_states: sgm_sweep_state_bytes()). The top half's
/// rows are H / 2:
/// 1. the right view's codes mirrored (sgm_mirror_rows());
/// 2. task 0 walks the top-to-bottom path down the top half, task 1 the bottom-to-top path up the
///    bottom half, each making a block's bands and costs, writing its sums and adding both
///    horizontal paths of its rows;
/// 3. task 0 walks its path on down the bottom half, task 1 its path on up the top half, each
///    adding into the sums and picking the winners of its rows.
void sgm_two_sweeps(const SgmSegmentJob& job, SgmScratch& scratch, SgmVolume& volume);

}  // namespace mctstereo::detail::cpu
