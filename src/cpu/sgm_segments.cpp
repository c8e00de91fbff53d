// Band SGM in segments of rows: the recipe of src/cpu/sgm_segments.hpp over the cpu stages' row
// ranges.
#include "cpu/sgm_segments.hpp"

#include <algorithm>
#include <cstdlib>

namespace mctstereo::detail::cpu {

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
    costs(first, last);
    const SgmRowState from_below = s + 1 < segments ? state(s + 1, last) : SgmRowState{};
    sgm_vertical_rows(*job.gray, job.paths, scratch, v, first, last, -1, kWriteSums, from_below, nullptr);
    sgm_vertical_rows(*job.gray, job.paths, scratch, v, first, last, +1, kAddSums, above, &above);
    sgm_horizontal_rows(*job.gray, job.paths, scratch, v, first, last);
    sgm_select_rows(v, job.select, scratch, *job.left_map, job.right_map, job.margin, first, last);
  }
  v.row0 = 0;
}

}  // namespace mctstereo::detail::cpu
