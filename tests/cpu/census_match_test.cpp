// cpu::census_match (the codes made strip by strip in rings of rows, then the strip's tiles
// matched) against reference::census_match (census_transform in whole planes, then match), bit
// for bit: every census variant and SHD window, one and both views, full ranges and ranges around
// coarse priors, margins, awkward sizes and images tall enough for strips of several tile rows,
// on every SIMD target with 1 and 2 threads.
#include <omp.h>

#include <array>
#include <optional>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::CensusMatchJob;
using detail::kInvalid;
using detail::MatchScratch;

struct Case {
  int w, h;
  detail::CensusConfig census{CensusKind::Census, 5, MeanKernel::Gaussian};
  int shd = 5;
  int views = 2;
  int dmin = 0, dmax = 15;
  int radius = -1;  // >= 0: ranges around coarse priors (20 % invalid) with this radius
  bool subpixel = true;
  int uniqueness = 15;
  bool right_even_rows = false;  // the right view matched at its even rows only
  std::uint32_t seed = 1;
};

constexpr std::int16_t kUntouched = 12345;

/// Valid pixels of the reference's left map (so that callers can check the case had work).
long expect_same(const Case& c) {
  const ShiftedPair pair = shifted_pair(c.w, c.h, c.seed, 4);
  std::array<Plane<std::int16_t>, 2> prior;
  CensusMatchJob job;
  job.image = {&pair.left, &pair.right};
  job.census = c.census;
  // The views' loops run over a constant 0..1 (GCC cannot see that c.views <= 2 and warns of an
  // overflow of the two-entry arrays otherwise).
  const auto matched = [&](int v) { return v < c.views; };
  job.views = c.views;
  for (int v = 0; v < 2 && matched(v); ++v) {
    const Plane<std::int16_t>* p = nullptr;
    if (c.radius >= 0) {
      prior[v] = random_disparity((c.w + 1) / 2, (c.h + 1) / 2, c.seed + 10 + v, 16 * (c.dmin / 2),
                                  16 * ((c.dmax + 1) / 2), 0.2, true);
      p = &prior[v];
    }
    job.ranges[v] = detail::SearchRanges::around(p, c.dmin, c.dmax, std::max(c.radius, 0));
    job.config[v] = {v == 0 ? -1 : +1, c.shd, c.subpixel, c.uniqueness, v == 1 && c.right_even_rows};
  }
  const int range = c.dmax - c.dmin + 1;

  std::array<Plane<std::int16_t>, 2> expected;
  Plane<std::uint8_t> expected_margin(c.w, c.h);
  std::array<detail::CensusCodes, 2> codes = {code_planes(c.w, c.h, c.census.window),
                                              code_planes(c.w, c.h, c.census.window)};
  for (int v = 0; v < 2 && matched(v); ++v) {
    expected[v].reset(c.w, c.h);
    for (int y = 0; y < c.h; ++y) std::fill_n(expected[v].row(y), c.w, kUntouched);
    job.disparity[v] = &expected[v];
  }
  job.margin = &expected_margin;
  job.codes = codes.data();
  MatchScratch ref_scratch =
      thread_scratch<MatchScratch>(whole_lines(detail::reference::census_match_scratch_bytes(c.w, range, c.shd, 0)), 1);
  detail::reference::census_match(job, ref_scratch);
  long valid = 0;
  for (int y = 0; y < c.h; ++y)
    for (int x = 0; x < c.w; ++x) valid += expected[0].at(x, y) != kInvalid;

  job.codes = nullptr;  // the cpu backend needs no code planes
  const int words = detail::census_words(c.census.window);
  MatchScratch scratch =
      thread_scratch<MatchScratch>(whole_lines(detail::cpu::census_match_scratch_bytes(c.w, range, c.shd, words)), 2);
  const int saved_threads = omp_get_max_threads();
  for_each_library_target([&](const std::string& target) {
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      std::array<Plane<std::int16_t>, 2> got;
      for (int v = 0; v < 2 && matched(v); ++v) {
        got[v].reset(c.w, c.h);
        for (int y = 0; y < c.h; ++y) std::fill_n(got[v].row(y), c.w, kUntouched);
        job.disparity[v] = &got[v];
      }
      Plane<std::uint8_t> margin(c.w, c.h);
      job.margin = threads == 2 ? &margin : nullptr;  // with and without the margins
      detail::cpu::census_match(job, scratch);
      const std::string what = target + ", " + std::to_string(threads) + " threads, " + std::to_string(c.w) + "x" +
                               std::to_string(c.h) + ", " + census_config_name(c.census) + ", a " +
                               std::to_string(c.shd) + ", radius " + std::to_string(c.radius);
      for (int v = 0; v < 2 && matched(v); ++v) EXPECT_EQ(first_difference(expected[v], got[v]), "") << what << ", view " << v;
      if (threads == 2) EXPECT_EQ(first_difference(expected_margin, margin), "") << what << ", margins";
    }
  });
  omp_set_num_threads(saved_threads);
  return valid;
}

// MatchConfig::even_rows: the right view's odd rows are left as they were by both backends, and
// its even rows are matched as without it.
TEST(CpuCensusMatch, RightViewAtEvenRowsOnly) {
  std::uint32_t seed = 90;
  for (auto [w, h] : awkward_sizes()) {
    if (w * h > 100000) w = 181, h = 167;
    for (int radius : {-1, 1}) {
      Case c{w, h};
      c.dmax = std::min(w + 2, 20);
      c.radius = radius;
      c.right_even_rows = true;
      c.seed = ++seed;
      expect_same(c);
    }
  }
}

TEST(CpuCensusMatch, RightViewAtEvenRowsOnlyMatchesThoseRowsAsAlways) {
  // The reference with and without even_rows: equal at the even rows, untouched at the odd ones.
  Case c{77, 41};
  const ShiftedPair pair = shifted_pair(c.w, c.h, 7, 4);
  std::array<Plane<std::int16_t>, 2> maps;
  for (int even : {0, 1}) {
    CensusMatchJob job;
    job.image = {&pair.left, &pair.right};
    job.census = c.census;
    job.views = 2;
    for (int v = 0; v < 2; ++v) {
      job.ranges[v] = detail::SearchRanges::around(nullptr, c.dmin, c.dmax, 0);
      job.config[v] = {v == 0 ? -1 : +1, c.shd, c.subpixel, c.uniqueness, v == 1 && even == 1};
    }
    std::array<Plane<std::int16_t>, 2> out;
    std::array<detail::CensusCodes, 2> codes = {code_planes(c.w, c.h, c.census.window),
                                                code_planes(c.w, c.h, c.census.window)};
    for (int v = 0; v < 2; ++v) {
      out[v].reset(c.w, c.h);
      for (int y = 0; y < c.h; ++y) std::fill_n(out[v].row(y), c.w, kUntouched);
      job.disparity[v] = &out[v];
    }
    job.codes = codes.data();
    MatchScratch scratch = thread_scratch<MatchScratch>(
        whole_lines(detail::reference::census_match_scratch_bytes(c.w, c.dmax - c.dmin + 1, c.shd, 0)), 1);
    detail::reference::census_match(job, scratch);
    maps[even] = std::move(out[1]);
  }
  int matched = 0;
  for (int y = 0; y < c.h; ++y)
    for (int x = 0; x < c.w; ++x) {
      if (y % 2 == 0) {
        ASSERT_EQ(maps[1].at(x, y), maps[0].at(x, y)) << x << ", " << y;
        matched += maps[1].at(x, y) != kInvalid;
      } else {
        ASSERT_EQ(maps[1].at(x, y), kUntouched) << x << ", " << y;
      }
    }
  EXPECT_GT(matched, c.w * c.h / 4);
}

TEST(CpuCensusMatch, AwkwardSizesBothViews) {
  std::uint32_t seed = 10;
  for (auto [w, h] : awkward_sizes()) {
    if (w * h > 100000) w = 181, h = 167;  // a smaller odd size instead of the large one: quicker
    Case c{w, h};
    c.dmax = std::min(w + 2, 20);
    c.seed = ++seed;
    const long valid = expect_same(c);
    EXPECT_GT(valid, 0) << w << "x" << h;
  }
}

TEST(CpuCensusMatch, EveryCensusVariantAndShdWindow) {
  // 41 x 290: 19 tile rows, so that one thread takes strips of several tile rows and the rings
  // wrap many times; every window half (0..4) above and below a tile.
  std::uint32_t seed = 40;
  int shd_index = 0;
  for (const detail::CensusConfig& census : all_census_configs()) {
    Case c{41, 290};
    c.census = census;
    c.shd = 1 + 2 * (shd_index++ % 5);
    c.seed = ++seed;
    EXPECT_GT(expect_same(c), 41 * 290 / 4) << census_config_name(census);
  }
}

TEST(CpuCensusMatch, RangesAroundCoarsePriorsAndTheLeftViewAlone) {
  std::uint32_t seed = 70;
  for (const auto& [w, h] : {std::pair{97, 203}, std::pair{130, 35}, std::pair{64, 16}, std::pair{5, 70}}) {
    for (int radius = 0; radius <= 3; ++radius) {
      Case c{w, h};
      c.dmin = -4;
      c.dmax = 30;
      c.radius = radius;
      c.shd = radius % 2 == 0 ? 5 : 3;
      c.views = radius == 3 ? 1 : 2;
      c.subpixel = radius >= 2;
      c.uniqueness = radius % 2 == 1 ? 15 : 0;
      c.seed = ++seed;
      expect_same(c);
    }
  }
}

TEST(CpuCensusMatch, TallImageWithManyStrips) {
  // 1000 rows: 63 tile rows, strips of 7 (2 threads) and 8 (1 thread) tile rows.
  Case c{70, 1000};
  c.census = {CensusKind::ModifiedCensus, 9, MeanKernel::Gaussian};
  c.shd = 9;
  c.seed = 99;
  EXPECT_GT(expect_same(c), 70 * 1000 / 4);
}

}  // namespace
}  // namespace mctstereo::test
