#include <algorithm>
#include <bit>
#include <climits>

#include "stages.hpp"

namespace mctstereo::detail::reference {

std::size_t match_scratch_bytes(int /*width*/, int max_range, int /*shd_window*/) {
  return static_cast<std::size_t>(max_range) * sizeof(int);
}

void match(const CensusCodes& ref, const CensusCodes& other, const SearchRanges& ranges,
           const MatchConfig& config, MatchScratch& scratch, Plane<std::int16_t>& disparity,
           Plane<std::uint8_t>* margin) {
  const int w = ref.plane[0].width(), h = ref.plane[0].height();
  const int hr = config.shd_window / 2;
  int* cost = reinterpret_cast<int*>(scratch.data.get());

  for (int y = 0; y < h; y += config.even_rows ? 2 : 1) {
    for (int x = 0; x < w; ++x) {
      const auto [dlo, dhi] = ranges.at(x, y);
      // Candidates whose matching pixel x + dir * d lies in the image: a contiguous interval.
      int first = INT_MAX, last = INT_MIN;
      for (int d = dlo; d <= dhi; ++d) {
        const int xo = x + config.dir * d;
        if (xo < 0 || xo >= w) continue;
        first = std::min(first, d);
        last = std::max(last, d);
        int c = 0;
        for (int j = -hr; j <= hr; ++j) {
          const int yy = clamp_index(y + j, h);
          for (int i = -hr; i <= hr; ++i) {
            const int xr = clamp_index(x + i, w);
            const int xs = clamp_index(x + i + config.dir * d, w);
            for (int k = 0; k < ref.words; ++k)
              c += std::popcount(ref.plane[k].at(xr, yy) ^ other.plane[k].at(xs, yy));
          }
        }
        cost[d - dlo] = c;
      }
      if (first > last) {
        disparity.at(x, y) = kInvalid;
        if (margin != nullptr) margin->at(x, y) = 0;
        continue;
      }
      int best = first;
      for (int d = first + 1; d <= last; ++d)
        if (cost[d - dlo] < cost[best - dlo]) best = d;  // strict: ties keep the smaller d
      const int best_cost = cost[best - dlo];

      // The second best: the smallest cost outside best - 1 .. best + 1 (INT_MAX: none).
      int second = INT_MAX;
      for (int d = first; d <= last; ++d)
        if (d < best - 1 || d > best + 1) second = std::min(second, cost[d - dlo]);
      if (margin != nullptr) margin->at(x, y) = sgm_margin(best_cost, second, best > first && best < last);
      if (config.uniqueness_ratio > 0 && second != INT_MAX &&
          100 * (second - best_cost) <= config.uniqueness_ratio * best_cost) {
        disparity.at(x, y) = kInvalid;
        continue;
      }
      int q4 = 16 * best;
      if (config.subpixel && best > first && best < last)
        q4 += subpixel_offset_q4(cost[best - 1 - dlo], best_cost, cost[best + 1 - dlo]);
      disparity.at(x, y) = static_cast<std::int16_t>(q4);
    }
  }
}

}  // namespace mctstereo::detail::reference
