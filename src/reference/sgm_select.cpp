// Winners on the SGM sums, for the left view and, from the same sums, for the right view.
#include <algorithm>
#include <climits>

#include "stages.hpp"

namespace mctstereo::detail::reference {

namespace {

// Winner of one pixel over its candidate sums sum(d), d in [first, last] where present(d).
// Returns kInvalid without a candidate or when the uniqueness test fails.
template <typename Sum, typename Present>
std::int16_t select_one(int first, int last, Sum sum, Present present, const SgmSelectConfig& config,
                        std::uint8_t* margin) {
  int best = INT_MIN, best_sum = INT_MAX;
  for (int d = first; d <= last; ++d)
    if (present(d) && sum(d) < best_sum) best_sum = sum(d), best = d;  // strict: ties keep the smaller d
  if (margin) *margin = 0;
  if (best == INT_MIN) return kInvalid;
  int second = INT_MAX;
  for (int d = first; d <= last; ++d)
    if (present(d) && (d < best - 1 || d > best + 1)) second = std::min(second, sum(d));
  if (margin) *margin = sgm_margin(best_sum, second, present(best - 1) && present(best + 1));
  return sgm_winner_q4(best, best_sum, second, present(best - 1) ? sum(best - 1) : -1,
                       present(best + 1) ? sum(best + 1) : -1, config);
}

}  // namespace

void sgm_select(const SgmVolume& volume, const SgmSelectConfig& config, SgmScratch& /*scratch*/,
                Plane<std::int16_t>& left, Plane<std::int16_t>* right, Plane<std::uint8_t>* margin) {
  const int w = volume.width, h = volume.height;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int lo = volume.lo.at(x, y), count = volume.count.at(x, y);
      const std::uint16_t* sum = volume.sum_at(x, y);
      left.at(x, y) = select_one(
          lo, lo + count - 1, [&](int d) { return static_cast<int>(sum[d - lo]); },
          [&](int d) { return d >= lo && d < lo + count; }, config, margin ? &margin->at(x, y) : nullptr);
    }
  }
  if (right == nullptr) return;
  // Right pixel x takes d from the left pixel x + d, where that pixel searched d.
  int dmin = INT_MAX, dmax = INT_MIN;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (volume.count.at(x, y) > 0) {
        dmin = std::min(dmin, static_cast<int>(volume.lo.at(x, y)));
        dmax = std::max(dmax, volume.lo.at(x, y) + volume.count.at(x, y) - 1);
      }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const auto present = [&](int d) {
        const int xl = x + d;
        if (xl < 0 || xl >= w) return false;
        const int lo = volume.lo.at(xl, y);
        return d >= lo && d < lo + volume.count.at(xl, y);
      };
      const auto sum = [&](int d) { return static_cast<int>(volume.sum_at(x + d, y)[d - volume.lo.at(x + d, y)]); };
      right->at(x, y) = select_one(dmin, dmax, sum, present, config, nullptr);
    }
  }
}

}  // namespace mctstereo::detail::reference
