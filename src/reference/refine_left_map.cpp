#include <algorithm>

#include "stages.hpp"

namespace mctstereo::detail::reference {

// The stages one after the other on whole maps, as the driver runs them elsewhere.
void refine_left_map(Plane<std::int16_t>& left, Plane<std::int16_t>& right, const LeftMapRefinement& config,
                     MatchScratch& scratch, Plane<std::int16_t>& spare, Plane<std::int16_t>& out) {
  // The checked map goes where neither of its inputs is: out after medians into out and spare,
  // left (no longer read) after them; then the post-median (or a copy) brings it to out.
  Plane<std::int16_t>* checked = &out;
  // What the left map is checked against: the right map's partners on its grid, its median, or
  // the raw map; the first two in spare.
  const Plane<std::int16_t>* partner = &right;
  if (config.grid || config.median_size > 0) {
    if (config.grid) grid_partner(right, config.median_size, scratch, spare);
    else median_filter(right, config.median_size, spare);
    partner = &spare;
  }
  if (config.median_size > 0) {
    median_filter(left, config.median_size, out);
    lr_check(out, *partner, -1, config.threshold_q4, left);
    checked = &left;
  } else {
    lr_check(left, *partner, -1, config.threshold_q4, out);
  }
  fill_invalid(*checked, config.fill);
  if (config.post_median_size > 0) {
    Plane<std::int16_t>& dst = checked == &out ? spare : out;
    median_filter(*checked, config.post_median_size, dst);
    if (&dst == &out) return;
    checked = &dst;
  }
  if (checked == &out) return;
  for (int y = 0; y < out.height(); ++y) std::copy_n(checked->row(y), out.width(), out.row(y));
}

std::size_t refine_left_map_scratch_bytes(int /*width*/) { return 0; }

}  // namespace mctstereo::detail::reference
