// The codes of both views in whole planes, then each view's matching: the two stages in order.
#include "stages.hpp"

namespace mctstereo::detail::reference {

std::size_t census_match_scratch_bytes(int width, int max_range, int shd_window, int /*census_words*/) {
  return match_scratch_bytes(width, max_range, shd_window);
}

void census_match(const CensusMatchJob& job, MatchScratch& scratch) {
  for (int v = 0; v < 2; ++v) census_transform(*job.image[v], job.census, job.codes[v]);
  for (int v = 0; v < job.views; ++v)
    match(job.codes[v], job.codes[1 - v], job.ranges[v], job.config[v], scratch, *job.disparity[v],
          v == 0 ? job.margin : nullptr);
}

}  // namespace mctstereo::detail::reference
