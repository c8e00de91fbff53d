// cpu::match against reference::match, bit for bit: sizes, strides, both views, SHD windows,
// census words, full / negative / nearly image-wide / per-pixel ranges (given as planes and made
// by the search rule around a prior), sub-pixel, uniqueness, the winners' margins, candidate
// chunking, on every SIMD target and with 1 and 2 threads.
#include <omp.h>

#include <algorithm>
#include <optional>
#include <random>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::CensusCodes;
using detail::kInvalid;
using detail::MatchConfig;
using detail::MatchScratch;

/// Per-pixel ranges as planes and, where they come from the pipeline's rule, the rule itself:
/// match() must give the same result from either form.
struct Ranges {
  Plane<std::int16_t> lo, hi;
  std::optional<detail::SearchRanges> rule;
};

/// Per-pixel ranges as the pipeline makes them; `prior` null = the whole range [dmin, dmax].
/// `pad` widens the rows (and so the stride) beyond the image.
Ranges ranges(int w, int h, const Plane<std::int16_t>* prior, int dmin, int dmax, int radius, int pad = 0) {
  Ranges r{Plane<std::int16_t>(w, h, pad), Plane<std::int16_t>(w, h, pad),
           detail::SearchRanges::around(prior, dmin, dmax, radius)};
  detail::reference::search_ranges(prior, dmin, dmax, radius, r.lo, r.hi);
  return r;
}

struct Stats {
  long valid = 0, fractional = 0;
  long partial_margin = 0;  // pixels whose margin is strictly between 0 and 255
};

/// Compares cpu::match with reference::match on every target and 1 / 2 threads (with 2 threads
/// the margins too, so that both the plain and the margin-tracking paths run on every target);
/// returns counts of the reference output so that callers can check the case was not vacuous.
Stats expect_same(const CensusCodes& ref, const CensusCodes& other, const Ranges& r, const MatchConfig& config,
                  std::size_t cpu_scratch_bytes = 0, int out_pad = 0) {
  const int w = ref.plane[0].width(), h = ref.plane[0].height();
  int max_range = 1;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) max_range = std::max(max_range, r.hi.at(x, y) - r.lo.at(x, y) + 1);
  MatchScratch ref_scratch =
      thread_scratch<MatchScratch>(detail::reference::match_scratch_bytes(w, max_range, config.shd_window), 1);
  Plane<std::int16_t> expected(w, h);
  Plane<std::uint8_t> expected_margin(w, h);
  const auto planes = detail::SearchRanges::planes(r.lo, r.hi);
  detail::reference::match(ref, other, planes, config, ref_scratch, expected, &expected_margin);
  {
    // Asking for the margins changes nothing else.
    Plane<std::int16_t> without(w, h);
    detail::reference::match(ref, other, planes, config, ref_scratch, without);
    EXPECT_EQ(first_difference(expected, without), "") << "reference with and without margins";
  }
  if (r.rule) {
    Plane<std::int16_t> by_rule(w, h);
    detail::reference::match(ref, other, *r.rule, config, ref_scratch, by_rule);
    EXPECT_EQ(first_difference(expected, by_rule), "") << "reference, ranges by the rule";
  }

  Stats stats;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int v = expected.at(x, y);
      stats.valid += v != kInvalid;
      stats.fractional += v != kInvalid && (v & 15) != 0;
      stats.partial_margin += expected_margin.at(x, y) > 0 && expected_margin.at(x, y) < 255;
    }

  // The driver rounds the slices to 64 bytes; tests that pass their own size may leave them odd.
  if (cpu_scratch_bytes == 0)
    cpu_scratch_bytes = whole_lines(detail::cpu::match_scratch_bytes(w, max_range, config.shd_window));
  MatchScratch scratch = thread_scratch<MatchScratch>(cpu_scratch_bytes, 2);
  const int saved_threads = omp_get_max_threads();
  for_each_library_target([&](const std::string& target) {
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      for (const detail::SearchRanges* form : {&planes, r.rule ? &*r.rule : nullptr}) {
        if (form == nullptr) continue;
        Plane<std::int16_t> got(w, h, out_pad);
        // Sentinels in the pad columns: the stage must write exactly the image pixels.
        for (int y = 0; y < h; ++y)
          for (int x = -out_pad; x < w + out_pad; ++x) got.row(y)[x] = 12345;
        Plane<std::uint8_t> margin(w, h, out_pad);
        for (int y = 0; y < h; ++y)
          for (int x = -out_pad; x < w + out_pad; ++x) margin.row(y)[x] = 77;
        const bool with_margin = threads == 2;
        detail::cpu::match(ref, other, *form, config, scratch, got, with_margin ? &margin : nullptr);
        if (with_margin) {
          EXPECT_EQ(first_difference(expected_margin, margin), "")
              << target << ", margins, " << w << "x" << h << ", dir " << config.dir << ", a " << config.shd_window
              << ", uniqueness " << config.uniqueness_ratio;
          for (int y = 0; y < h; ++y)
            for (int x = 1; x <= out_pad; ++x) {
              ASSERT_EQ(margin.row(y)[-x], 77) << target;
              ASSERT_EQ(margin.row(y)[w - 1 + x], 77) << target;
            }
        }
        EXPECT_EQ(first_difference(expected, got), "")
            << target << ", " << threads << " threads, " << w << "x" << h << ", ranges "
            << (form == &planes ? "from planes" : "by the rule") << ", dir " << config.dir << ", a "
            << config.shd_window << ", words " << ref.words << ", subpixel " << config.subpixel << ", uniqueness "
            << config.uniqueness_ratio;
        for (int y = 0; y < h; ++y)
          for (int x = 1; x <= out_pad; ++x) {
            ASSERT_EQ(got.row(y)[-x], 12345) << target;
            ASSERT_EQ(got.row(y)[w - 1 + x], 12345) << target;
          }
      }
    }
  });
  omp_set_num_threads(saved_threads);
  return stats;
}

TEST(CpuMatch, AwkwardSizesBothViewsFullRange) {
  std::uint32_t seed = 100;
  for (const auto& [w, h] : awkward_sizes()) {
    const bool large = w * h > 100000;
    const ShiftedPair pair = shifted_pair(w, h, ++seed, 3);
    const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
    const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
    const Ranges r = ranges(w, h, nullptr, 0, large ? 15 : std::min(w + 2, 24), 0);
    for (int dir : {-1, +1}) {
      if (large && dir > 0) continue;  // the large size once keeps the test quick
      MatchConfig config{dir, 5, dir < 0, dir < 0 ? 15 : 0};
      const Stats s = dir < 0 ? expect_same(left, right, r, config) : expect_same(right, left, r, config);
      EXPECT_GT(s.valid, 0) << w << "x" << h;
      if (w >= 15) EXPECT_GT(s.partial_margin, 0) << w << "x" << h;
    }
  }
}

TEST(CpuMatch, PaddedStridesOfRangesAndOutput) {
  const int w = 77, h = 21;
  const ShiftedPair pair = shifted_pair(w, h, 7, 4);
  const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
  const Ranges r = ranges(w, h, nullptr, 0, 12, 0, /*pad=*/37);
  for (int dir : {-1, +1}) {
    const MatchConfig config{dir, 3, true, 0};
    expect_same(dir < 0 ? left : right, dir < 0 ? right : left, r, config, 0, /*out_pad=*/19);
  }
}

TEST(CpuMatch, EveryShdWindowCensusWindowAndWordCount) {
  const int w = 70, h = 19;
  std::uint32_t seed = 300;
  for (int census_window : {3, 5, 7, 9}) {
    for (CensusKind kind : {CensusKind::Census, CensusKind::ModifiedCensus}) {
      const ShiftedPair pair = shifted_pair(w, h, ++seed, 6);
      const CensusCodes left = reference_census(pair.left, census_window, kind);
      const CensusCodes right = reference_census(pair.right, census_window, kind);
      ASSERT_EQ(left.words, detail::census_words(census_window));
      const Ranges r = ranges(w, h, nullptr, 0, 20, 0);
      for (int a : {1, 3, 5, 7, 9}) {
        const int dir = (a / 2) % 2 == 0 ? -1 : +1;
        const MatchConfig config{dir, a, a != 1, a == 5 || a == 9 ? 15 : 0};
        const Stats s = dir < 0 ? expect_same(left, right, r, config) : expect_same(right, left, r, config);
        EXPECT_GT(s.valid, w * h / 2);
      }
    }
  }
}

TEST(CpuMatch, SubpixelAndUniquenessAllCombinations) {
  const int w = 90, h = 33;
  const ShiftedPair pair = shifted_pair(w, h, 21, 5);
  const CensusCodes left = reference_census(pair.left, 7, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 7, CensusKind::Census);
  const Ranges r = ranges(w, h, nullptr, 0, 15, 0);
  for (bool subpixel : {false, true})
    for (int uniqueness : {0, 15, 60}) {
      const MatchConfig config{-1, 5, subpixel, uniqueness};
      const Stats s = expect_same(left, right, r, config);
      EXPECT_GT(s.valid, 0);
      EXPECT_GT(s.partial_margin, w * h / 4);
      if (subpixel && uniqueness < 60) EXPECT_GT(s.fractional, 0);
      if (!subpixel) EXPECT_EQ(s.fractional, 0);
    }
}

TEST(CpuMatch, RandomCodesWithManyTies) {
  // Uncorrelated noise images: many candidates share the best cost, so the tie rule is exercised;
  // a = 1 gives the smallest cost spread.
  const int w = 67, h = 13;
  const CensusCodes left = reference_census(random_image(w, h, 5), 3, CensusKind::Census);
  const CensusCodes right = reference_census(random_image(w, h, 6), 3, CensusKind::Census);
  const Ranges r = ranges(w, h, nullptr, 0, 30, 0);
  for (int a : {1, 3})
    for (bool subpixel : {false, true})
      for (int uniqueness : {0, 15}) expect_same(left, right, r, {-1, a, subpixel, uniqueness});
}

TEST(CpuMatch, NegativeMinimumDisparity) {
  const int w = 83, h = 27;
  const ShiftedPair pair = shifted_pair(w, h, 31, -7);
  const CensusCodes left = reference_census(pair.left, 5, CensusKind::ModifiedCensus);
  const CensusCodes right = reference_census(pair.right, 5, CensusKind::ModifiedCensus);
  const Ranges r = ranges(w, h, nullptr, -20, 10, 0);
  for (int dir : {-1, +1}) {
    const MatchConfig config{dir, 5, true, 15};
    const Stats s = dir < 0 ? expect_same(left, right, r, config) : expect_same(right, left, r, config);
    EXPECT_GT(s.valid, w * h / 2);
  }
}

TEST(CpuMatch, RangeNearlyAsWideAsTheImage) {
  const int w = 40, h = 11;
  const ShiftedPair pair = shifted_pair(w, h, 41, 9);
  const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
  const Ranges r = ranges(w, h, nullptr, 0, 38, 0);
  for (int dir : {-1, +1})
    for (int a : {1, 5, 9}) {
      const MatchConfig config{dir, a, true, 15};
      expect_same(dir < 0 ? left : right, dir < 0 ? right : left, r, config);
    }
}

TEST(CpuMatch, RangesBeyondTheImageLeaveBorderPixelsInvalid) {
  // Only disparities 50..60 on a 56-wide image: most pixels have no candidate at all.
  const int w = 56, h = 9;
  const ShiftedPair pair = shifted_pair(w, h, 43, 2);
  const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
  const Ranges r = ranges(w, h, nullptr, 50, 60, 0);
  for (int dir : {-1, +1}) {
    const Stats s = expect_same(dir < 0 ? left : right, dir < 0 ? right : left, r, {dir, 5, true, 15});
    EXPECT_GT(s.valid, 0);
    EXPECT_LT(s.valid, w * h);
  }
}

TEST(CpuMatch, VariedPerPixelRangesFromACoarsePrior) {
  std::uint32_t seed = 500;
  for (const auto& [w, h] : {std::pair{97, 41}, std::pair{64, 16}, std::pair{130, 35}, std::pair{5, 70}}) {
    const ShiftedPair pair = shifted_pair(w, h, ++seed, 6);
    const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
    const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
    const int dmin = -4, dmax = 30;
    for (int radius = 0; radius <= 3; ++radius) {
      // Whole-pixel priors of the coarser level (half the range), 20 % invalid.
      const Plane<std::int16_t> prior =
          random_disparity((w + 1) / 2, (h + 1) / 2, ++seed, 16 * (dmin / 2), 16 * ((dmax + 1) / 2), 0.2, true);
      const Ranges r = ranges(w, h, &prior, dmin, dmax, radius);
      for (int dir : {-1, +1}) {
        const MatchConfig config{dir, radius % 2 == 0 ? 5 : 3, radius >= 2, radius % 2 == 1 ? 15 : 0};
        expect_same(dir < 0 ? left : right, dir < 0 ? right : left, r, config);
      }
    }
  }
}

TEST(CpuMatch, RangesByTheRuleAtAwkwardSizesAndPriorSizes) {
  // The tile-local ranges around a prior (one coarse row per two tile rows, tiles cut through
  // coarse columns, odd widths and heights reading the last coarse column or row, a prior of
  // floor(W / 2) as well as the pipeline's ceil(W / 2)) against the reference rule.
  std::uint32_t seed = 900;
  int radius = 0;
  for (auto [w, h] : awkward_sizes()) {
    if (w * h > 100000) w = 181, h = 67;  // a smaller odd size instead of the large one: quicker
    const ShiftedPair pair = shifted_pair(w, h, ++seed, 4);
    const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
    const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
    for (bool ceil_half : {true, false}) {
      const int cw = ceil_half ? (w + 1) / 2 : w / 2, ch = ceil_half ? (h + 1) / 2 : h / 2;
      if (cw == 0 || ch == 0) continue;
      const Plane<std::int16_t> prior = random_disparity(cw, ch, ++seed, -16 * 3, 16 * 12, 0.2, true);
      const Ranges r = ranges(w, h, &prior, -4, 22, radius);
      radius = (radius + 1) % 4;
      for (int dir : {-1, +1})
        expect_same(dir < 0 ? left : right, dir < 0 ? right : left, r, {dir, 5, true, dir < 0 ? 15 : 0});
    }
  }
}

TEST(CpuMatch, SmoothPriorLikeTheFinestLevel) {
  // A slanted surface seen through the pyramid: prior = 2 x (a plane at half resolution).
  const int w = 150, h = 60;
  const ShiftedPair pair = shifted_pair(w, h, 61, 8);
  const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
  Plane<std::int16_t> prior((w + 1) / 2, (h + 1) / 2);
  for (int y = 0; y < prior.height(); ++y)
    for (int x = 0; x < prior.width(); ++x) prior.at(x, y) = static_cast<std::int16_t>(16 * (2 + x / 12 + y / 9));
  for (int radius : {2, 3}) {
    const Ranges r = ranges(w, h, &prior, 0, 31, radius);
    const Stats s = expect_same(left, right, r, {-1, 5, true, 15});
    EXPECT_GT(s.valid, w * h / 2);
    EXPECT_GT(s.fractional, 0);
  }
}

TEST(CpuMatch, CandidateChunksWhenTheScratchIsSmall) {
  // A scratch sized for 3 candidates forces the band through several chunks; the WTA state then
  // carries from chunk to chunk, also across the per-pixel hulls of a varied prior.
  const int w = 101, h = 37;
  const ShiftedPair pair = shifted_pair(w, h, 71, 5);
  const CensusCodes left = reference_census(pair.left, 9, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 9, CensusKind::Census);
  const std::size_t small = detail::cpu::match_scratch_bytes(w, 3, 5);
  const Ranges full = ranges(w, h, nullptr, -3, 28, 0);
  const Plane<std::int16_t> prior = random_disparity((w + 1) / 2, (h + 1) / 2, 72, 0, 16 * 13, 0.2, true);
  const Ranges varied = ranges(w, h, &prior, -3, 28, 1);
  for (const Ranges* r : {&full, &varied})
    for (bool subpixel : {false, true})
      for (int uniqueness : {0, 15}) {
        const Stats s = expect_same(left, right, *r, {-1, 5, subpixel, uniqueness}, small);
        EXPECT_GT(s.valid, 0);
        EXPECT_GT(s.partial_margin, 0);
      }
}

TEST(CpuMatch, ArbitraryRangesIncludingEmptyOnes) {
  // Not what search_ranges makes: independent random lo and hi per pixel, so that some intervals
  // are empty (lo > hi), some single candidates, and neighbours differ wildly.
  const int w = 71, h = 23;
  const ShiftedPair pair = shifted_pair(w, h, 81, 3);
  const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
  Ranges r{Plane<std::int16_t>(w, h), Plane<std::int16_t>(w, h), std::nullopt};
  std::mt19937 rng(82);
  std::uniform_int_distribution<int> dist(-12, 40);
  int empty = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      r.lo.at(x, y) = static_cast<std::int16_t>(dist(rng));
      r.hi.at(x, y) = static_cast<std::int16_t>(dist(rng));
      empty += r.lo.at(x, y) > r.hi.at(x, y);
    }
  ASSERT_GT(empty, 0);
  for (int dir : {-1, +1})
    for (bool subpixel : {false, true}) {
      const Stats s = expect_same(dir < 0 ? left : right, dir < 0 ? right : left, r, {dir, 3, subpixel, 15});
      EXPECT_GT(s.valid, 0);
      EXPECT_LT(s.valid, w * h);
    }
}

TEST(CpuMatch, ScratchSlicesNeedNotBeAligned) {
  // Slices of an odd size: the stage aligns each thread's slice itself.
  const int w = 90, h = 40;
  const ShiftedPair pair = shifted_pair(w, h, 91, 4);
  const CensusCodes left = reference_census(pair.left, 5, CensusKind::Census);
  const CensusCodes right = reference_census(pair.right, 5, CensusKind::Census);
  const Ranges r = ranges(w, h, nullptr, 0, 20, 0);
  const std::size_t odd = detail::cpu::match_scratch_bytes(w, 21, 5) + 40;
  expect_same(left, right, r, {-1, 5, true, 15}, odd);
}

// The scratch is one tile's: the same for any image width (the function takes no height), growing
// with the range up to the chunk of 256 candidates and no further.
TEST(CpuMatch, ScratchFollowsTheRangeUpToAChunkNotTheWidth) {
  EXPECT_EQ(detail::cpu::match_scratch_bytes(640, 64, 5), detail::cpu::match_scratch_bytes(64, 64, 5));
  EXPECT_EQ(detail::cpu::match_scratch_bytes(4096, 64, 5), detail::cpu::match_scratch_bytes(64, 64, 5));
  EXPECT_LT(detail::cpu::match_scratch_bytes(640, 64, 5), detail::cpu::match_scratch_bytes(640, 128, 5));
  EXPECT_EQ(detail::cpu::match_scratch_bytes(640, 256, 5), detail::cpu::match_scratch_bytes(640, 2048, 9));
  // Under 2 MiB per thread even for the widest chunk (16 rows x 64 columns x 256 candidates x 2 bytes).
  EXPECT_LT(detail::cpu::match_scratch_bytes(640, 2048, 9), std::size_t{2} << 20);
}

}  // namespace
}  // namespace mctstereo::test
