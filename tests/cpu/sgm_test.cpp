// Band SGM stages: known answers of the band rule and of the path recursion, and cpu::sgm_* against
// reference::sgm_* bit for bit (bands, costs, sums, both views' winners, margins, confidence) on
// seeded random pairs and on scenes with depth edges, at awkward sizes (odd widths, 1 and 2 rows),
// negative minimum disparities, 256+ disparities, bands cut at max_band and at the range ends,
// 4 and 8 paths, constant and adaptive P2, every SIMD target, 1 and 2 threads.
#include <omp.h>

#include <algorithm>
#include <initializer_list>
#include <random>

#include "cpu/sgm_segments.hpp"
#include "level_plan.hpp"
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;
using detail::kSgmInf;
using detail::SgmBandConfig;
using detail::SgmPathConfig;
using detail::SgmScratch;
using detail::SgmSelectConfig;
using detail::SgmVolume;

// A volume with its own storage: 16-bit costs, or bytes (SgmVolume::use_byte_costs()).
struct OwnedVolume {
  SgmVolume v;
  std::unique_ptr<std::uint16_t[], detail::FreeDeleter> cost, sum;
  std::unique_ptr<std::uint8_t[], detail::FreeDeleter> cost8;
  OwnedVolume(int w, int h, int band, int words, bool byte_costs = false) {
    const std::size_t n = SgmVolume::entries_for(w, h, band);
    cost = detail::allocate_aligned<std::uint16_t>(n);
    sum = detail::allocate_aligned<std::uint16_t>(n);
    v.reset(w, h, band, words, cost.get(), sum.get());
    if (byte_costs) {
      cost8 = detail::allocate_aligned<std::uint8_t>(n);
      v.use_byte_costs(cost8.get());
    }
  }
};

SgmScratch make_scratch(std::size_t bytes, int threads) { return thread_scratch<SgmScratch>(whole_lines(bytes), threads); }

TEST(SgmBand, RuleKnownAnswers) {
  // Coarse 3 x 3 map (Q4): priors 2, 3, 4 / 5, 6, 7 / invalid, 9, 10 px.
  Plane<std::int16_t> coarse = make_map(3, 3, {32, 48, 64, 80, 96, 112, kInvalid, 144, 160});
  const SgmBandConfig five{0, 40, 2, 5, 64}, three{0, 40, 2, 3, 64};
  // Pixel (2, 2) reads coarse (1, 1) = 6: the 5x5 covers every valid prior, 2..10 -> [2, 22];
  // then the image clip d <= x = 2 leaves [2, 2].
  EXPECT_EQ(detail::sgm_band_at(&coarse, five, 100, 2, 2).lo, 2);
  EXPECT_EQ(detail::sgm_band_at(&coarse, five, 100, 2, 2).hi, 2);
  // Pixel (50, 2) of a wide level: no image clip.
  const auto wide = detail::sgm_band_at(&coarse, five, 100, 50, 2);
  EXPECT_EQ(wide.lo, 2);
  EXPECT_EQ(wide.hi, 22);
  // Pixel (60, 0) reads coarse (2, 0) = 4 (columns clamp to the coarse width); its 3x3 holds
  // 3, 4, 6, 7 -> [6 - 2, 14 + 2].
  const auto small = detail::sgm_band_at(&coarse, three, 100, 60, 0);
  EXPECT_EQ(small.lo, 4);
  EXPECT_EQ(small.hi, 16);
  // Pixel (1, 4) reads coarse (0, 2), invalid: the whole range, clipped to d <= 1.
  const auto whole = detail::sgm_band_at(&coarse, five, 100, 1, 4);
  EXPECT_EQ(whole.lo, 0);
  EXPECT_EQ(whole.hi, 1);
  // max_band 5 cuts [2, 22] around 2 x 6 = 12 (pixel (2, 2) reads coarse (1, 1)): [10, 14]; at
  // x = 50 (coarse column clamped to 2, prior 7) around 14: [12, 16].
  const SgmBandConfig cut{0, 40, 2, 5, 5};
  const auto c = detail::sgm_band_at(&coarse, cut, 100, 2, 3);
  EXPECT_EQ(c.lo, 2);  // the image clip d <= 2 comes first
  EXPECT_EQ(c.hi, 2);
  const auto c2 = detail::sgm_band_at(&coarse, cut, 100, 50, 2);
  EXPECT_EQ(c2.lo, 12);
  EXPECT_EQ(c2.hi, 16);
  const auto c3 = detail::sgm_band_at(&coarse, cut, 100, 13, 3);  // coarse (6 -> 2, 1) = 7: [12, 16], clip d <= 13
  EXPECT_EQ(c3.lo, 9);  // [2, 13] is 12 wide: cut around 14 -> clamp(12, 2, 9) = 9
  EXPECT_EQ(c3.hi, 13);
  // No prior: the level range, clipped to 0 <= x - d < W.
  const auto none = detail::sgm_band_at(nullptr, SgmBandConfig{-5, 20, 2, 5, 64}, 30, 3, 0);
  EXPECT_EQ(none.lo, -5);
  EXPECT_EQ(none.hi, 3);
  const auto right_edge = detail::sgm_band_at(nullptr, SgmBandConfig{-5, 20, 2, 5, 64}, 30, 27, 0);
  EXPECT_EQ(right_edge.lo, -2);
  // A range entirely outside the image: empty.
  const auto empty = detail::sgm_band_at(nullptr, SgmBandConfig{10, 20, 2, 5, 64}, 30, 3, 0);
  EXPECT_GT(empty.lo, empty.hi);
}

TEST(SgmAggregate, RecursionKnownAnswer) {
  // A 3 x 1 level, whole range 0..1 clipped by the image: pixel 0 has d = 0 only, pixels 1, 2
  // have d = 0, 1. Costs set by hand; constant P2.
  OwnedVolume o(3, 1, 2, 1);
  SgmVolume& v = o.v;
  const int lo[3] = {0, 0, 0}, count[3] = {1, 2, 2};
  const std::uint16_t costs[3][2] = {{10, kSgmInf}, {50, 5}, {7, 40}};
  for (int x = 0; x < 3; ++x) {
    v.lo.at(x, 0) = static_cast<std::int16_t>(lo[x]);
    v.count.at(x, 0) = static_cast<std::int16_t>(count[x]);
    for (int k = 0; k < v.stride; ++k) v.cost_at(x, 0)[k] = k < 2 ? costs[x][k] : kSgmInf;
  }
  Plane<std::uint8_t> gray(3, 1);
  const SgmPathConfig config{4, 3, 20, 0};
  auto scratch = make_scratch(detail::reference::sgm_scratch_bytes(3, 1, v.stride), 1);
  detail::reference::sgm_aggregate(gray, config, scratch, v);
  // Left to right: L0 = {10}; L1 = {50 + min(10, 10 + 20) - 10, 5 + min(inf, 10 + 3, 30) - 10} = {50, 8};
  //   L2 = {7 + min(50, 8 + 3, 8 + 20) - 8, 40 + min(8, 50 + 3, 28) - 8} = {10, 40}.
  // Right to left: L2 = {7, 40}; L1 = {50 + min(7, 40 + 3, 27) - 7, 5 + min(40, 7 + 3, 27) - 7} = {50, 8};
  //   L0 = {10 + min(50, 8 + 3, 28) - 8} = {13}.
  // Top-down and bottom-up: one row, L = C.
  EXPECT_EQ(v.sum_at(0, 0)[0], 10 + 13 + 10 + 10);
  EXPECT_EQ(v.sum_at(0, 0)[1], kSgmInf);
  EXPECT_EQ(v.sum_at(1, 0)[0], 50 + 50 + 50 + 50);
  EXPECT_EQ(v.sum_at(1, 0)[1], 8 + 8 + 5 + 5);
  EXPECT_EQ(v.sum_at(2, 0)[0], 10 + 7 + 7 + 7);
  EXPECT_EQ(v.sum_at(2, 0)[1], 40 + 40 + 40 + 40);
  // Winners: pixel 0 -> 0, pixel 1 -> 1 (26 < 200), pixel 2 -> 0 (31 < 160).
  Plane<std::int16_t> left(3, 1), right(3, 1);
  detail::reference::sgm_select(v, SgmSelectConfig{false, 0}, scratch, left, &right, nullptr);
  EXPECT_EQ(left.at(0, 0), 0);
  EXPECT_EQ(left.at(1, 0), 16);
  EXPECT_EQ(left.at(2, 0), 0);
  // Right pixel 0: d = 0 from left 0 (43), d = 1 from left 1 (26) -> 1. Right 1: d = 0 (200),
  // d = 1 from left 2 (160) -> 1. Right 2: d = 0 only (31).
  EXPECT_EQ(right.at(0, 0), 16);
  EXPECT_EQ(right.at(1, 0), 16);
  EXPECT_EQ(right.at(2, 0), 0);
}

// Adaptive P2 (docs/PIPELINE.md): P2' = max(P1, P2 k / (k + |a - b|)), P2 itself with k = 0.
TEST(SgmAggregate, AdaptiveP2KnownAnswers) {
  const SgmPathConfig adaptive{4, 60, 200, 16};
  EXPECT_EQ(detail::sgm_p2_at(adaptive, 10, 10), 200);
  EXPECT_EQ(detail::sgm_p2_at(adaptive, 10, 26), 100);      // 200 x 16 / 32
  EXPECT_EQ(detail::sgm_p2_at(adaptive, 26, 10), 100);      // symmetric
  EXPECT_EQ(detail::sgm_p2_at(adaptive, 0, 30), 69);        // 3200 / 46, truncated
  EXPECT_EQ(detail::sgm_p2_at(adaptive, 0, 255), 60);       // 3200 / 271 = 11, raised to P1
  EXPECT_EQ(detail::sgm_p2_at({4, 60, 200, 0}, 0, 255), 200);  // constant P2
  // The same floor inside the recursion: a gray step of 255 between two pixels of one row costs a
  // jump of P1 (not 11) from the left neighbour's best.
  OwnedVolume o(2, 1, 4, 1);
  SgmVolume& v = o.v;
  const std::uint16_t costs[2][4] = {{0, 90, 90, 90}, {90, 90, 90, 0}};
  for (int x = 0; x < 2; ++x) {
    v.lo.at(x, 0) = 0;
    v.count.at(x, 0) = 4;
    for (int k = 0; k < v.stride; ++k) v.cost_at(x, 0)[k] = k < 4 ? costs[x][k] : kSgmInf;
  }
  Plane<std::uint8_t> gray(2, 1);
  gray.at(0, 0) = 0;
  gray.at(1, 0) = 255;
  auto scratch = make_scratch(detail::reference::sgm_scratch_bytes(2, 1, v.stride), 1);
  detail::reference::sgm_aggregate(gray, adaptive, scratch, v);
  // Left to right at pixel 1, d = 3: 0 + min(L0(3) = 90, L0(2) + P1 = 150, min L0 + P2' = 0 + 60) - 0 = 60.
  // Right to left at pixel 1 and both vertical paths: L = C = 0.
  EXPECT_EQ(v.sum_at(1, 0)[3], 60 + 0 + 0 + 0);
}

// Everything the stages produce, for comparison.
struct SgmResult {
  Plane<std::int16_t> lo, count, left, right;
  Plane<std::uint8_t> margin, confidence;
  std::vector<std::uint16_t> cost, sum;
};

struct SgmCase {
  int w, h, dmin, dmax, radius, prior_size, max_band, shd, census, paths, p2k;
  bool with_prior, subpixel;
  int uniqueness;
};

std::string describe(const SgmCase& c) {
  return std::to_string(c.w) + "x" + std::to_string(c.h) + " d [" + std::to_string(c.dmin) + ", " +
         std::to_string(c.dmax) + "] r " + std::to_string(c.radius) + " prior " +
         (c.with_prior ? std::to_string(c.prior_size) : std::string("none")) + " band " + std::to_string(c.max_band) +
         " a " + std::to_string(c.shd) + " census " + std::to_string(c.census) + " paths " + std::to_string(c.paths) +
         " p2k " + std::to_string(c.p2k);
}

// A pair with a depth edge: a background at d0 and a square in front at d1, plus noise.
ShiftedPair edge_pair(int w, int h, std::uint32_t seed, int d0, int d1) {
  ShiftedPair p = shifted_pair(w, h, seed, d0);
  const Plane<std::uint8_t> front = random_texture(w, h, seed + 7);
  for (int y = h / 4; y < 3 * h / 4; ++y)
    for (int x = w / 4; x < 3 * w / 4; ++x) {
      p.left.at(x, y) = front.at(x, y);
      const int xr = x - d1;
      if (xr >= 0) p.right.at(xr, y) = front.at(x, y);
    }
  return p;
}

// Planes for every map of a w x h level.
SgmResult empty_result(int w, int h) {
  return SgmResult{Plane<std::int16_t>(w, h), Plane<std::int16_t>(w, h), Plane<std::int16_t>(w, h),
                   Plane<std::int16_t>(w, h), Plane<std::uint8_t>(w, h), Plane<std::uint8_t>(w, h), {}, {}};
}

// The volume's band starts and counts into the result.
void copy_bands(const SgmVolume& v, SgmResult& r) {
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x) {
      r.lo.at(x, y) = v.lo.at(x, y);
      r.count.at(x, y) = v.count.at(x, y);
    }
}

// byte_costs: the volume's costs in bytes (the case's costs must lie below kSgmInf8); the result
// holds them as 16-bit values either way.
template <typename Stages>
SgmResult run_stages(const SgmCase& c, const ShiftedPair& pair, const Plane<std::int16_t>* prior, int threads,
                     Stages stages, const detail::TemporalPrior& temporal = {}, bool byte_costs = false) {
  const int words = detail::census_words(c.census);
  const detail::CensusCodes left = reference_census(pair.left, c.census, CensusKind::Census);
  const detail::CensusCodes right = reference_census(pair.right, c.census, CensusKind::Census);
  OwnedVolume o(c.w, c.h, c.max_band, words, byte_costs);
  SgmVolume& v = o.v;
  const SgmBandConfig band{c.dmin, c.dmax, c.radius, c.prior_size, c.max_band, temporal};
  auto scratch = make_scratch(stages.scratch_bytes(c.w, c.h, v.stride), threads);
  stages.costs(left, right, prior, band, c.shd, scratch, v);
  stages.aggregate(pair.left, SgmPathConfig{c.paths, 20, 150, c.p2k}, scratch, v);
  SgmResult r = empty_result(c.w, c.h);
  stages.select(v, SgmSelectConfig{c.subpixel, c.uniqueness}, scratch, r.left, &r.right, &r.margin);
  stages.confidence(r.margin, 0, r.left, &r.right, 1, r.confidence);
  copy_bands(v, r);
  const std::size_t n = SgmVolume::entries_for(c.w, c.h, c.max_band);
  r.cost.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto slot = static_cast<int>(i / static_cast<std::size_t>(v.stride));
    r.cost[i] = static_cast<std::uint16_t>(v.cost_value(slot % c.w, slot / c.w, static_cast<int>(i % v.stride)));
  }
  r.sum.assign(v.sum, v.sum + n);
  return r;
}

struct ReferenceStages {
  decltype(&detail::reference::sgm_costs) costs = &detail::reference::sgm_costs;
  decltype(&detail::reference::sgm_aggregate) aggregate = &detail::reference::sgm_aggregate;
  decltype(&detail::reference::sgm_scratch_bytes) scratch_bytes = &detail::reference::sgm_scratch_bytes;
  decltype(&detail::reference::sgm_select) select = &detail::reference::sgm_select;
  decltype(&detail::reference::confidence) confidence = &detail::reference::confidence;
};
struct CpuStages {
  decltype(&detail::cpu::sgm_costs) costs = &detail::cpu::sgm_costs;
  decltype(&detail::cpu::sgm_aggregate) aggregate = &detail::cpu::sgm_aggregate;
  decltype(&detail::cpu::sgm_scratch_bytes) scratch_bytes = &detail::cpu::sgm_scratch_bytes;
  decltype(&detail::cpu::sgm_select) select = &detail::cpu::sgm_select;
  decltype(&detail::cpu::confidence) confidence = &detail::cpu::confidence;
};

// The index of the first differing entry, or -1.
template <typename T>
long first_index(const std::vector<T>& a, const std::vector<T>& b) {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i] != b[i]) return static_cast<long>(i);
  return -1;
}

// The maps of the whole volume: band, winners of both views, margins, confidence.
void expect_equal_maps(const SgmResult& ref, const SgmResult& got, const std::string& what) {
  EXPECT_EQ(first_difference(ref.lo, got.lo), "") << what << ": band start";
  EXPECT_EQ(first_difference(ref.count, got.count), "") << what << ": band count";
  EXPECT_EQ(first_difference(ref.left, got.left), "") << what << ": left map";
  EXPECT_EQ(first_difference(ref.right, got.right), "") << what << ": right map";
  EXPECT_EQ(first_difference(ref.margin, got.margin), "") << what << ": margin";
  EXPECT_EQ(first_difference(ref.confidence, got.confidence), "") << what << ": confidence";
}

void expect_equal(const SgmResult& ref, const SgmResult& got, const std::string& what) {
  expect_equal_maps(ref, got, what);
  EXPECT_EQ(first_index(ref.cost, got.cost), -1) << what << ": costs";
  EXPECT_EQ(first_index(ref.sum, got.sum), -1) << what << ": sums";
}

std::vector<SgmCase> sgm_cases() {
  std::vector<SgmCase> cases;
  // Coarsest levels (no prior): the whole range, wide and negative ranges, 256+ disparities.
  cases.push_back({61, 23, 0, 15, 0, 5, 16, 3, 5, 4, 8, false, true, 0});
  cases.push_back({67, 9, -7, 12, 0, 5, 20, 3, 5, 8, 0, false, true, 10});
  cases.push_back({300, 3, 0, 269, 0, 5, 270, 3, 5, 4, 8, false, true, 0});
  cases.push_back({33, 1, -3, 20, 0, 5, 24, 5, 7, 4, 8, false, false, 0});
  cases.push_back({17, 2, 0, 9, 0, 5, 10, 1, 9, 8, 8, false, true, 5});
  cases.push_back({1, 5, 0, 3, 0, 5, 4, 3, 5, 4, 8, false, true, 0});
  // Slots of 64 entries: two vectors of 32 lanes where the target has them.
  cases.push_back({83, 7, -11, 52, 0, 5, 64, 3, 5, 8, 8, false, true, 10});
  // Finer levels: bands around a prior, cut at max_band, at the range ends.
  cases.push_back({97, 31, 0, 63, 3, 5, 32, 3, 5, 4, 8, true, true, 10});
  cases.push_back({64, 17, 0, 63, 2, 3, 8, 3, 5, 8, 8, true, true, 0});
  cases.push_back({45, 13, -20, 30, 6, 5, 12, 3, 9, 4, 0, true, true, 0});
  cases.push_back({129, 2, 0, 40, 3, 5, 16, 5, 5, 4, 8, true, false, 10});
  cases.push_back({75, 19, -4, 90, 9, 5, 48, 3, 5, 4, 8, true, false, 0});
  return cases;
}

// A prior for a level w x h: a coarse map (ceil(w/2) x ceil(h/2)) near the true disparities with
// noise, jumps and some invalid pixels.
Plane<std::int16_t> make_prior(int w, int h, int dmin, int dmax, std::uint32_t seed) {
  const int cw = (w + 1) / 2, ch = (h + 1) / 2;
  const int lo = 16 * (dmin >> 1), hi = 16 * (-((-dmax) >> 1));
  return random_disparity(cw, ch, seed, lo, hi, 0.1, true);
}

TEST(SgmMargin, FastEqualsTheIntegerQuotient) {
  // Every second best S2 with 64 best sums S1 <= S2 each (both ends, neighbours of the values
  // where 255 (S2 - S1) / S2 crosses an integer, and seeded random ones).
  std::mt19937 rng(7);
  int checked = 0;
  for (int s2 = 1; s2 <= 65534; ++s2) {
    std::uniform_int_distribution<int> any(0, s2);
    for (int i = 0; i < 64; ++i) {
      int s1;
      if (i < 4) s1 = std::clamp(i < 2 ? i : s2 - (i - 2), 0, s2);
      else if (i < 32) s1 = std::clamp(s2 - (s2 * ((i - 4) * 9 + 1)) / 255 + (i & 1), 0, s2);
      else s1 = any(rng);
      ASSERT_EQ(detail::sgm_margin_fast(s1, s2, i & 1), detail::sgm_margin(s1, s2, i & 1)) << s1 << " " << s2;
      ++checked;
    }
  }
  EXPECT_EQ(detail::sgm_margin_fast(5, std::numeric_limits<int>::max(), true), 255);
  EXPECT_EQ(detail::sgm_margin_fast(5, std::numeric_limits<int>::max(), false), 0);
  EXPECT_EQ(detail::sgm_margin_fast(0, 0, true), 0);
  EXPECT_EQ(detail::sgm_margin_fast(1, 3, false), 170);  // 255 x 2 / 3
  EXPECT_EQ(checked, 65534 * 64);
}

// The confidence with the margins of a level 2^s times smaller (box levels under band SGM): each
// pixel takes the margin at (x >> s, y >> s). Known answers without a right map (agreement 1),
// and the cpu stage equal to the reference with one, at odd sizes, 1 and 2 threads.
TEST(SgmConfidence, MarginOfACoarserLevel) {
  for (const auto& [w, h] : {std::pair{37, 11}, std::pair{64, 1}, std::pair{1, 9}, std::pair{130, 67}}) {
    const Plane<std::int16_t> left = random_disparity(w, h, 5 + w, 0, 16 * 12, 0.2);
    const Plane<std::int16_t> right = random_disparity(w, h, 9 + h, 0, 16 * 12, 0.2);
    for (int shift : {0, 1, 2}) {
      SCOPED_TRACE(testing::Message() << w << "x" << h << " shift " << shift);
      const int mw = ((w - 1) >> shift) + 1, mh = ((h - 1) >> shift) + 1;
      Plane<std::uint8_t> margin(mw, mh), want(w, h), got(w, h);
      std::mt19937 rng(static_cast<std::uint32_t>(w * 31 + shift));
      for (int y = 0; y < mh; ++y)
        for (int x = 0; x < mw; ++x) margin.at(x, y) = static_cast<std::uint8_t>(rng() & 0xFF);
      detail::reference::confidence(margin, shift, left, nullptr, 1, want);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          ASSERT_EQ(want.at(x, y), left.at(x, y) == kInvalid ? 0 : margin.at(x >> shift, y >> shift)) << x << "," << y;
      detail::reference::confidence(margin, shift, left, &right, 1, want);
      const int saved = omp_get_max_threads();
      for (int threads : {1, 2}) {
        omp_set_num_threads(threads);
        detail::cpu::confidence(margin, shift, left, &right, 1, got);
        EXPECT_EQ(first_difference(got, want), "") << threads << " threads";
      }
      omp_set_num_threads(saved);
    }
  }
}

// A pair for a case: a depth edge for odd seeds, a plain shift for even ones.
ShiftedPair case_pair(const SgmCase& c, std::uint32_t seed) {
  return (seed % 2) ? edge_pair(c.w, c.h, seed, std::max(c.dmin, 0) + 2, std::min(c.dmax, c.w - 1))
                    : shifted_pair(c.w, c.h, seed, std::clamp(c.dmin + 3, c.dmin, c.dmax));
}

TEST(SgmStages, CpuEqualsReference) {
  std::uint32_t seed = 11;
  for (const SgmCase& c : sgm_cases()) {
    const ShiftedPair pair = case_pair(c, seed);
    const Plane<std::int16_t> prior = make_prior(c.w, c.h, c.dmin, c.dmax, seed + 3);
    ++seed;
    const Plane<std::int16_t>* p = c.with_prior ? &prior : nullptr;
    const SgmResult ref = run_stages(c, pair, p, 1, ReferenceStages{});
    // The case must exercise what it claims: candidates everywhere but at the clipped border.
    int valid = 0;
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w; ++x) valid += ref.left.at(x, y) != kInvalid;
    EXPECT_GT(valid, 0) << describe(c);
    // Byte costs wherever the case's costs fit them, as the pipeline takes them: the reference
    // with them equals itself with 16-bit costs, and cpu equals both.
    const bool bytes = detail::sgm_byte_costs(c.shd, c.census);
    if (bytes) expect_equal(ref, run_stages(c, pair, p, 1, ReferenceStages{}, {}, true), describe(c) + ", byte costs");
    const int saved = omp_get_max_threads();
    for_each_simd_target([&](const std::string& target) {
      for (int threads : {1, 2}) {
        omp_set_num_threads(threads);
        for (bool byte_costs : {false, true}) {
          if (byte_costs && !bytes) continue;
          expect_equal(ref, run_stages(c, pair, p, threads, CpuStages{}, {}, byte_costs),
                       describe(c) + " on " + target + ", " + std::to_string(threads) + " thread(s)" +
                           (byte_costs ? ", byte costs" : ""));
        }
      }
    });
    omp_set_num_threads(saved);
  }
}

TEST(SgmStages, ByteCostsWhereEveryCostFits) {
  // CT 5x5 (24 bits) with 3x3 boxes: at most 216, bytes; 5x5 boxes: 600, 16 bits. 255 is the
  // byte costs' "not a candidate", so a largest cost of 255 takes 16 bits.
  EXPECT_EQ(detail::sgm_max_cost(3, 5), 216);
  EXPECT_TRUE(detail::sgm_byte_costs(3, 5));
  EXPECT_TRUE(detail::sgm_byte_costs(1, 9));   // 80
  EXPECT_TRUE(detail::sgm_byte_costs(3, 3));   // 72
  EXPECT_FALSE(detail::sgm_byte_costs(5, 5));  // 600
  EXPECT_FALSE(detail::sgm_byte_costs(3, 7));  // 432
  // The plan: the three SGM levels take bytes; with a 5x5 box at the finest level that level
  // takes 16 bits, and the storage is sized for the largest of entries x entry size.
  StereoParams q = sgm_every_level();
  q.num_disparities = 64;
  const detail::LevelPlan plan = detail::plan_levels(q, 640, 480, true);
  for (const detail::LevelSpec& L : plan.levels) EXPECT_TRUE(L.sgm_byte_costs);
  EXPECT_EQ(plan.sgm_cost_bytes, plan.sgm_entries);
  q.shd_window = 5;
  const detail::LevelPlan wide = detail::plan_levels(q, 640, 480, true);
  EXPECT_FALSE(wide.finest().sgm_byte_costs);
  EXPECT_TRUE(wide.levels[1].sgm_byte_costs);
  EXPECT_EQ(wide.sgm_cost_bytes, 2 * wide.sgm_entries);
  // A byte volume reads back kSgmInf past the count and the values below kSgmInf8 as written.
  OwnedVolume o(2, 1, 3, 1, true);
  o.v.set_cost(0, 0, 0, 254);
  o.v.set_cost(0, 0, 1, kSgmInf);
  o.v.set_cost(1, 0, 2, 0);
  EXPECT_EQ(o.v.cost_value(0, 0, 0), 254);
  EXPECT_EQ(o.v.cost_value(0, 0, 1), kSgmInf);
  EXPECT_EQ(o.v.cost_value(1, 0, 2), 0);
  EXPECT_EQ(o.cost8[1], detail::kSgmInf8);
}

// The bands with the temporal prior (every case with a coarser prior): a previous map near twice
// the prior (sub-pixel values, jumps, invalid pixels) and images in which some pixels moved (changed
// by 13 > threshold 12) and some did not (changed by 12).
TEST(SgmStages, TemporalBandsCpuEqualReference) {
  std::uint32_t seed = 40;
  long narrowed = 0;  // bands the prior narrowed (a band already cut to max_band may stay as it is)
  for (const SgmCase& c : sgm_cases()) {
    if (!c.with_prior) continue;
    const ShiftedPair pair = edge_pair(c.w, c.h, seed, std::max(c.dmin, 0) + 2, std::min(c.dmax, c.w - 1));
    const Plane<std::int16_t> prior = make_prior(c.w, c.h, c.dmin, c.dmax, seed + 3);
    const Plane<std::int16_t> jitter = random_disparity(c.w, c.h, seed + 5, -24, 24, 0.1);
    Plane<std::int16_t> previous(c.w, c.h);
    Plane<std::uint8_t> before(c.w, c.h);
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w; ++x) {
        const int p = prior.at(x / 2, y / 2), j = jitter.at(x, y);
        previous.at(x, y) = p == kInvalid || j == kInvalid
                                ? kInvalid
                                : static_cast<std::int16_t>(std::clamp(2 * p + j, 16 * c.dmin, 16 * c.dmax));
        // Changes of 13 and -13 (moved) and 12 (still) at every seventh pixel.
        const int change = (x + y) % 7 == 0 ? 13 : (x + y) % 7 == 3 ? -13 : (x + y) % 7 == 5 ? 12 : 0;
        const int value = pair.left.at(x, y);
        before.at(x, y) = static_cast<std::uint8_t>(value + change >= 0 && value + change <= 255 ? value + change
                                                                                                : value - change);
      }
    ++seed;
    for (int radius : {0, 1}) {
      const detail::TemporalPrior temporal{&previous, &pair.left, &before, radius, 12};
      const SgmResult ref = run_stages(c, pair, &prior, 1, ReferenceStages{}, temporal);
      const SgmResult alone = run_stages(c, pair, &prior, 1, ReferenceStages{});
      for (int y = 0; y < c.h; ++y)
        for (int x = 0; x < c.w; ++x) narrowed += ref.count.at(x, y) < alone.count.at(x, y);
      const int saved = omp_get_max_threads();
      for_each_simd_target([&](const std::string& target) {
        for (int threads : {1, 2}) {
          omp_set_num_threads(threads);
          expect_equal(ref, run_stages(c, pair, &prior, threads, CpuStages{}, temporal),
                       describe(c) + " temporal radius " + std::to_string(radius) + " on " + target + ", " +
                           std::to_string(threads) + " thread(s)");
        }
      });
      omp_set_num_threads(saved);
    }
  }
  EXPECT_GT(narrowed, 1000);
}

// cpu::sgm_segmented() with segments of `rows` rows (storage for one segment's costs and sums,
// mirrored planes of a segment's rows and the box's margins), or with `sweeps` cpu::sgm_two_sweeps()
// in blocks of `rows` rows over a whole volume.
SgmResult run_segmented(const SgmCase& c, const ShiftedPair& pair, const Plane<std::int16_t>* prior, int threads,
                        int rows, bool byte_costs, bool sweeps = false) {
  const int words = detail::census_words(c.census);
  const detail::CensusCodes left = reference_census(pair.left, c.census, CensusKind::Census);
  const detail::CensusCodes right = reference_census(pair.right, c.census, CensusKind::Census);
  const std::size_t n = SgmVolume::entries_for(c.w, sweeps ? c.h : rows, c.max_band);
  auto cost = detail::allocate_aligned<std::uint16_t>(n);
  auto sum = detail::allocate_aligned<std::uint16_t>(n);
  auto cost8 = detail::allocate_aligned<std::uint8_t>(n);
  SgmVolume v;
  v.reset(c.w, c.h, c.max_band, words, cost.get(), sum.get(), sweeps ? 0 : std::min(c.h, rows + 2 * (c.shd / 2)));
  if (byte_costs) v.use_byte_costs(cost8.get());
  const std::size_t state_bytes = sweeps ? detail::cpu::sgm_sweep_state_bytes(c.w, v.stride)
                                         : detail::cpu::sgm_row_state_bytes(c.w, c.h, v.stride, rows);
  auto states = detail::allocate_aligned<std::uint16_t>(state_bytes / 2);
  auto scratch = make_scratch(detail::cpu::sgm_scratch_bytes(c.w, c.h, v.stride), threads);
  SgmResult r = empty_result(c.w, c.h);
  const detail::cpu::SgmSegmentJob job{&left, &right, prior, SgmBandConfig{c.dmin, c.dmax, c.radius, c.prior_size, c.max_band},
                                       c.shd, &pair.left, SgmPathConfig{c.paths, 20, 150, c.p2k},
                                       SgmSelectConfig{c.subpixel, c.uniqueness}, rows, states.get(), &r.left, &r.right,
                                       &r.margin};
  if (sweeps)
    detail::cpu::sgm_two_sweeps(job, scratch, v);
  else
    detail::cpu::sgm_segmented(job, scratch, v);
  detail::cpu::confidence(r.margin, 0, r.left, &r.right, 1, r.confidence);
  copy_bands(v, r);
  return r;
}

// run_segmented() (segments, or with `sweeps` two sweeps) of every 4-path case in runs of each of
// `rows` rows (those up to the height) against the reference's whole volume, on every target,
// 1 and 2 threads.
void expect_rows_equal_reference(bool sweeps, std::uint32_t seed, std::initializer_list<int> rows_list) {
  const std::string recipe = sweeps ? " in two sweeps of blocks of " : " in segments of ";
  int cases = 0;
  for (const SgmCase& c : sgm_cases()) {
    if (c.paths != 4) continue;
    ++cases;
    const ShiftedPair pair = case_pair(c, seed);
    const Plane<std::int16_t> prior = make_prior(c.w, c.h, c.dmin, c.dmax, seed + 3);
    ++seed;
    const Plane<std::int16_t>* p = c.with_prior ? &prior : nullptr;
    const SgmResult ref = run_stages(c, pair, p, 1, ReferenceStages{});
    const bool bytes = detail::sgm_byte_costs(c.shd, c.census);
    const int saved = omp_get_max_threads();
    for_each_simd_target([&](const std::string& target) {
      for (int threads : {1, 2}) {
        omp_set_num_threads(threads);
        for (int rows : rows_list) {
          rows = std::min(rows, c.h);
          expect_equal_maps(ref, run_segmented(c, pair, p, threads, rows, bytes, sweeps),
                            describe(c) + recipe + std::to_string(rows) + " rows on " + target + ", " +
                                std::to_string(threads) + " thread(s)");
        }
      }
    });
    omp_set_num_threads(saved);
  }
  EXPECT_GE(cases, 8);
}

TEST(SgmSegments, CpuEqualsReferenceOverTheWholeVolume) {
  // Segments of 1, 2 and 3 rows, rows that do not divide the height, one segment of the whole
  // level (on 2 threads each segment in two sweeps).
  expect_rows_equal_reference(false, 70, {1, 2, 3, 7, 1 << 20});
}

TEST(SgmTwoSweeps, CpuEqualsReferenceOverTheWholeVolume) {
  // Blocks of 1, 2, 3 and 7 rows, of the driver's and of the whole level (1 and 2 rows high: a
  // half of none).
  expect_rows_equal_reference(true, 90, {1, 2, 3, 7, detail::cpu::kSweepRows, 1 << 20});
}

TEST(SgmSegments, PlanSegmentsLargeVolumesOnly) {
  StereoParams q = sgm_every_level();
  q.num_disparities = 256;
  const std::size_t limit = std::size_t{32} << 20;
  // 640 x 480 fits (28 MiB of costs and sums at the finest level): whole volumes.
  for (const detail::LevelSpec& L : detail::plan_levels(q, 640, 480, true, limit).levels)
    EXPECT_EQ(L.sgm_segment_rows, 0);
  // 1280 x 720: the finest level (84 MiB whole) in segments, and every level whose volume does
  // not fit one of its segments' storage; the storage is that of the largest segment.
  const detail::LevelPlan plan = detail::plan_levels(q, 1280, 720, true, limit);
  const detail::LevelPlan whole = detail::plan_levels(q, 1280, 720, true);
  EXPECT_GE(plan.finest().sgm_segment_rows, detail::kMinSegmentRows);
  EXPECT_LT(plan.finest().sgm_segment_rows, 64);
  for (std::size_t l = 0; l < plan.levels.size(); ++l) {
    const detail::LevelSpec& L = plan.levels[l];
    EXPECT_EQ(whole.levels[l].sgm_segment_rows, 0);
    EXPECT_LE(L.sgm_storage_entries(), plan.sgm_entries);
    if (L.sgm_segment_rows == 0) EXPECT_LE(SgmVolume::entries_for(L.width, L.height, L.sgm_band), plan.sgm_entries);
  }
  EXPECT_LT(plan.sgm_entries * 3 + plan.sgm_row_state_bytes, whole.sgm_entries * 3 / 10);
  // 8 paths keep the whole volume.
  q.aggregation = Aggregation::Sgm8;
  for (const detail::LevelSpec& L : detail::plan_levels(q, 1280, 720, true, limit).levels)
    EXPECT_EQ(L.sgm_segment_rows, 0);
}

TEST(SgmStages, PathsRecoverASteppedScene) {
  // A background at 4 and a square at 12: SGM on the whole range finds both inside the areas
  // away from the edges, on both views.
  const SgmCase c{80, 40, 0, 20, 0, 5, 21, 3, 5, 4, 8, false, false, 0};
  const ShiftedPair pair = edge_pair(c.w, c.h, 5, 4, 12);
  const SgmResult r = run_stages(c, pair, nullptr, 1, ReferenceStages{});
  int right_bg = 0, right_fg = 0, total_bg = 0, total_fg = 0;
  for (int y = 2; y < c.h - 2; ++y)
    for (int x = 22; x < c.w - 2; ++x) {
      const bool fg = y >= c.h / 4 + 2 && y < 3 * c.h / 4 - 2 && x >= c.w / 4 + 2 && x < 3 * c.w / 4 - 2;
      const bool bg = y < c.h / 4 - 2 || y >= 3 * c.h / 4 + 2;
      if (fg) ++total_fg, right_fg += r.left.at(x, y) == 16 * 12;
      if (bg) ++total_bg, right_bg += r.left.at(x, y) == 16 * 4;
    }
  EXPECT_GT(right_fg, total_fg * 95 / 100);
  EXPECT_GT(right_bg, total_bg * 95 / 100);
}

}  // namespace
}  // namespace mctstereo::test
