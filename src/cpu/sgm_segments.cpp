// Band SGM in segments of rows and in two sweeps: the recipes of src/cpu/sgm_segments.hpp over the
// cpu stages' row ranges.
#include "cpu/sgm_segments.hpp"

#include "cpu/parallel.hpp"

#include <algorithm>
#include <cstdlib>

namespace mctstereo::detail::cpu {

// One task's half of a sweep: its vertical path (task 0 down, task 1 up) over rows [a, b) in
// blocks of `rows`, from and into `state`. In the first sweep the block's bands and costs come
// first (the right view's codes mirrored already) and both horizontal paths after; in the second
// the block's winners after: each while the block is in the cache.
static void sweep_half(const SgmSegmentJob& job, SgmScratch& scratch, SgmVolume& v, int task, bool first_sweep,
                       int a, int b, int rows, SgmRowState& state) {
  const int dy = task == 0 ? +1 : -1;
  for (int i = 0; i < b - a; i += rows) {
    const int first = dy > 0 ? a + i : std::max(b - i - rows, a), last = dy > 0 ? std::min(a + i + rows, b) : b - i;
    if (first_sweep)
      sgm_costs_rows(*job.left, *job.right, job.coarse, job.band, job.shd_window, scratch, v, first, last, true);
    sgm_vertical_rows(*job.gray, job.paths, scratch, v, first, last, dy, first_sweep ? kWriteSums : kAddSums, state,
                      &state);
    if (first_sweep)
      sgm_horizontal_rows(*job.gray, job.paths, scratch, v, first, last);
    else
      sgm_select_rows(v, job.select, scratch, *job.left_map, job.right_map, job.margin, first, last);
  }
}

// The bands, costs, paths and winners of rows [first, last) of the volume in two sweeps, in
// blocks of `rows`, after mirroring the codes their windows read: state[0] holds the
// top-to-bottom path's values at the row above them (or none: y = -1) and leaves with those at
// their last row; state[1] the bottom-to-top path's at the row below them (or none).
static void two_sweeps(const SgmSegmentJob& job, SgmScratch& scratch, SgmVolume& v, int first, int last, int rows,
                       SgmRowState* state) {
  const int mid = first + (last - first) / 2;
  sgm_mirror_rows(*job.right, job.shd_window, v, first, last);
  for (const bool first_sweep : {true, false}) {
    // The first sweep's sums of a row are whole before the second adds into them: the sweeps
    // are two stages.
    parallel_for(
        2, 1,
        [&](int t0, int t1) {
          const SerialScope serial;
          for (int task = t0; task < t1; ++task) {
            const bool top = (task == 0) == first_sweep;
            sweep_half(job, scratch, v, task, first_sweep, top ? first : mid, top ? mid : last, rows, state[task]);
          }
        },
        scratch.threads);
  }
}

void sgm_segmented(const SgmSegmentJob& job, SgmScratch& scratch, SgmVolume& v) {
  if (job.paths.paths != 4) std::abort();  // the plan segments 4-path levels only
  const int h = v.height, rows = job.segment_rows, segments = sgm_segment_count(h, rows);
  // State 0: the top-to-bottom path's values at the last row of the segment above; state s > 0:
  // the bottom-to-top path's at the first row of segment s.
  const auto state = [&](int s, int y) {
    SgmRowState r = sgm_row_state(job.row_states, v.width, v.stride, s);
    r.y = y;
    return r;
  };
  const auto costs = [&](int first, int last) {
    v.row0 = first;
    sgm_costs_rows(*job.left, *job.right, job.coarse, job.band, job.shd_window, scratch, v, first, last);
  };
  // Up the level: the bottom-to-top path's checkpoints.
  SgmRowState below;
  for (int s = segments - 1; s > 0; --s) {
    const int first = s * rows, last = std::min(first + rows, h);
    costs(first, last);
    SgmRowState checkpoint = state(s, first);
    sgm_vertical_rows(*job.gray, job.paths, scratch, v, first, last, -1, kNoSums, below, &checkpoint);
    below = checkpoint;
  }
  // Down the level: every path of a segment, then its winners.
  SgmRowState above = state(0, -1);
  for (int s = 0; s < segments; ++s) {
    const int first = s * rows, last = std::min(first + rows, h);
    if (sgm_two_sweeps_for(job.paths.paths, std::min(scratch.threads, stage_threads()))) {
      // On 2 threads the segment's paths and winners in two sweeps (sgm_two_sweeps()): the
      // bottom-to-top path from the checkpoint below, in its storage (no longer needed), or
      // afresh in a free one (the last segment's checkpoint, or state 1 of one segment).
      SgmRowState paths[2] = {above, s + 1 < segments ? state(s + 1, last) : state(std::max(s, 1), -1)};
      v.row0 = first;
      two_sweeps(job, scratch, v, first, last, last - first, paths);
      above = paths[0];
      continue;
    }
    costs(first, last);
    const SgmRowState from_below = s + 1 < segments ? state(s + 1, last) : SgmRowState{};
    sgm_vertical_rows(*job.gray, job.paths, scratch, v, first, last, -1, kWriteSums, from_below, nullptr);
    sgm_vertical_rows(*job.gray, job.paths, scratch, v, first, last, +1, kAddSums, above, &above);
    sgm_horizontal_rows(*job.gray, job.paths, scratch, v, first, last);
    sgm_select_rows(v, job.select, scratch, *job.left_map, job.right_map, job.margin, first, last);
  }
  v.row0 = 0;
}

void sgm_two_sweeps(const SgmSegmentJob& job, SgmScratch& scratch, SgmVolume& v) {
  if (job.paths.paths != 4) std::abort();  // sgm_two_sweeps_for()
  v.row0 = 0;
  // Each task's path values at the last row it walked: they carry its path over from one sweep
  // to the next, whichever thread runs the task.
  SgmRowState state[2] = {sgm_row_state(job.row_states, v.width, v.stride, 0),
                          sgm_row_state(job.row_states, v.width, v.stride, 1)};
  two_sweeps(job, scratch, v, 0, v.height, job.segment_rows, state);
}

}  // namespace mctstereo::detail::cpu
