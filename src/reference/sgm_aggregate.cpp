// The SGM recursion in plain loops, one path after the other, each over the whole level.
#include <algorithm>
#include <climits>

#include "stages.hpp"

namespace mctstereo::detail::reference {

std::size_t sgm_scratch_bytes(int width, int height, int stride) {
  return static_cast<std::size_t>(width) * height * stride * sizeof(std::uint16_t);
}

namespace {

// L(p, d) for every candidate of p from its predecessor q along the path (q == nullptr: p starts
// the path, or q has no candidate). Candidates outside q's band are +inf: they never win, and the
// jump from m(q) always exists, so every value stays finite.
void path_step(const SgmVolume& v, int x, int y, int qx, int qy, bool has_q, const Plane<std::uint8_t>& gray,
               const SgmPathConfig& config, const std::uint16_t* lq, std::uint16_t* lp) {
  const int lo = v.lo.at(x, y), count = v.count.at(x, y);
  const int q_lo = has_q ? v.lo.at(qx, qy) : 0, q_count = has_q ? v.count.at(qx, qy) : 0;
  const auto l_q = [&](int d) { return d >= q_lo && d < q_lo + q_count ? static_cast<int>(lq[d - q_lo]) : INT_MAX / 2; };
  int m = INT_MAX;
  for (int k = 0; k < q_count; ++k) m = std::min(m, static_cast<int>(lq[k]));
  const int p2 = q_count > 0 ? sgm_p2_at(config, gray.at(x, y), gray.at(qx, qy)) : 0;
  for (int k = 0; k < v.stride; ++k) {
    if (k >= count) {
      lp[k] = kSgmInf;
      continue;
    }
    if (q_count == 0) {
      lp[k] = static_cast<std::uint16_t>(v.cost_value(x, y, k));
      continue;
    }
    const int d = lo + k;
    const int best = std::min({l_q(d), l_q(d - 1) + config.p1, l_q(d + 1) + config.p1, m + p2});
    lp[k] = static_cast<std::uint16_t>(v.cost_value(x, y, k) + best - m);
  }
}

}  // namespace

void sgm_aggregate(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                   SgmVolume& volume) {
  const int w = volume.width, h = volume.height, s = volume.stride;
  auto* path = reinterpret_cast<std::uint16_t*>(scratch.data.get());
  const auto at = [&](int x, int y) { return path + (static_cast<std::size_t>(y) * w + x) * s; };
  std::fill_n(volume.sum, static_cast<std::size_t>(w) * h * s, std::uint16_t{0});
  for (int r = 0; r < config.paths; ++r) {
    const int dx = kSgmSteps[r][0], dy = kSgmSteps[r][1];
    for (int yi = 0; yi < h; ++yi) {
      const int y = dy < 0 ? h - 1 - yi : yi;
      for (int xi = 0; xi < w; ++xi) {
        const int x = dx < 0 ? w - 1 - xi : xi;
        const int qx = x - dx, qy = y - dy;
        const bool inside = qx >= 0 && qx < w && qy >= 0 && qy < h;
        path_step(volume, x, y, qx, qy, inside, gray, config, inside ? at(qx, qy) : nullptr, at(x, y));
      }
    }
    // Sums of in-band values stay below kSgmInf (validate() bounds paths x (C_max + P2)).
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        std::uint16_t* sum = volume.sum_at(x, y);
        const std::uint16_t* l = at(x, y);
        const int count = volume.count.at(x, y);
        for (int k = 0; k < s; ++k) sum[k] = k < count ? static_cast<std::uint16_t>(sum[k] + l[k]) : kSgmInf;
      }
    }
  }
}

}  // namespace mctstereo::detail::reference
