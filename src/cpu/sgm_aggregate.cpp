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
#include <hwy/highway.h>

#include <omp.h>

#include <algorithm>

#include "stages.hpp"

#ifndef MCTSTEREO_CPU_SGM_AGGREGATE_ONCE
#define MCTSTEREO_CPU_SGM_AGGREGATE_ONCE
namespace mctstereo::detail::cpu {

// One padded buffer of path values: stride + 2 padding entries each side, and slack.
inline int path_buffer_entries(int stride) { return 3 * stride + 4 + 32; }

// Per thread: two path buffers for sgm_aggregate, or five int rows for sgm_select's right view.
std::size_t sgm_scratch_bytes(int width, int /*height*/, int stride) {
  return std::max(2 * static_cast<std::size_t>(path_buffer_entries(stride)) * sizeof(std::uint16_t),
                  5 * static_cast<std::size_t>(width) * sizeof(int));
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

HWY_BEFORE_NAMESPACE();
namespace mctstereo::detail::cpu::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DU16 = hn::CappedTag<std::uint16_t, 16>;

// Values of one path along one line, added into the sums (written when `first`).
void PathLine(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, int x, int y, int dx, int dy, bool first,
              std::uint16_t* buffers, SgmVolume& v) {
  const DU16 d;
  const int n = static_cast<int>(hn::Lanes(d));
  const int stride = v.stride, pad = stride + 2, w = v.width, h = v.height;
  const int entries = path_buffer_entries(stride);
  std::uint16_t* prev = buffers;
  std::uint16_t* cur = buffers + entries;
  std::fill_n(buffers, 2 * entries, kSgmInf);
  const auto p1 = hn::Set(d, static_cast<std::uint16_t>(config.p1));
  int m_prev = kSgmInf, lo_prev = 0, gray_prev = 0;
  for (; x >= 0 && x < w && y >= 0 && y < h; x += dx, y += dy) {
    const std::uint16_t* cost = v.cost_at(x, y);
    std::uint16_t* sum = v.sum_at(x, y);
    std::uint16_t* l = cur + pad;
    const int lo = v.lo.at(x, y), g = gray.at(x, y);
    auto vmin = hn::Set(d, kSgmInf);
    if (m_prev == kSgmInf) {
      // The path starts here (or its predecessor had no candidate): L = C.
      for (int k = 0; k < stride; k += n) {
        const auto c = hn::LoadU(d, cost + k);
        hn::StoreU(c, d, l + k);
        vmin = hn::Min(vmin, c);
      }
    } else {
      const int s = std::clamp(lo - lo_prev, -(stride + 1), stride + 1);
      const std::uint16_t* q = prev + pad + s;
      const auto m = hn::Set(d, static_cast<std::uint16_t>(m_prev));
      const auto jump = hn::Set(d, static_cast<std::uint16_t>(m_prev + sgm_p2_at(config, g, gray_prev)));
      for (int k = 0; k < stride; k += n) {
        const auto same = hn::LoadU(d, q + k);
        const auto below = hn::SaturatedAdd(hn::LoadU(d, q + k - 1), p1);
        const auto above = hn::SaturatedAdd(hn::LoadU(d, q + k + 1), p1);
        const auto t = hn::Min(hn::Min(same, jump), hn::Min(below, above));
        const auto value = hn::SaturatedAdd(hn::LoadU(d, cost + k), hn::Sub(t, m));
        hn::StoreU(value, d, l + k);
        vmin = hn::Min(vmin, value);
      }
    }
    for (int k = 0; k < stride; k += n) {
      const auto value = hn::LoadU(d, l + k);
      hn::StoreU(first ? value : hn::SaturatedAdd(hn::LoadU(d, sum + k), value), d, sum + k);
    }
    m_prev = hn::GetLane(hn::MinOfLanes(d, vmin));
    lo_prev = lo;
    gray_prev = g;
    std::swap(prev, cur);
  }
}

void SgmAggregate(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch, SgmVolume& v) {
  for (int r = 0; r < config.paths; ++r) {
    const PathLines lines{v.width, v.height, kSgmSteps[r][0], kSgmSteps[r][1]};
#pragma omp parallel num_threads(scratch.threads)
    {
      auto* buffers = reinterpret_cast<std::uint16_t*>(scratch.data.get() + omp_get_thread_num() * scratch.bytes_per_thread);
#pragma omp for schedule(dynamic, 4)
      for (int i = 0; i < lines.count(); ++i) {
        int x, y;
        lines.start(i, x, y);
        PathLine(gray, config, x, y, lines.dx, lines.dy, r == 0, buffers, v);
      }
    }
  }
}

}  // namespace mctstereo::detail::cpu::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace mctstereo::detail::cpu {
HWY_EXPORT(SgmAggregate);
void sgm_aggregate(const Plane<std::uint8_t>& gray, const SgmPathConfig& config, SgmScratch& scratch,
                   SgmVolume& volume) {
  HWY_DYNAMIC_DISPATCH(SgmAggregate)(gray, config, scratch, volume);
}
}  // namespace mctstereo::detail::cpu
#endif
