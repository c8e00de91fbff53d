// Refinement stages: known answers of the reference, and cpu == reference bit for bit.
#include <omp.h>

#include <algorithm>
#include <random>
#include <string>
#include <vector>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::kInvalid;
using detail::LeftMapRefinement;
using detail::MatchScratch;
using detail::SpeckleScratch;
namespace reference = detail::reference;
namespace cpu = detail::cpu;

constexpr std::int16_t I = kInvalid;

Plane<std::int16_t> copy_of(const Plane<std::int16_t>& p) {
  Plane<std::int16_t> c(p.width(), p.height());
  for (int y = 0; y < p.height(); ++y) std::copy(p.row(y), p.row(y) + p.width(), c.row(y));
  return c;
}

// The scratch for maps of w x h, with the labels the backend asks for (the cpu backend's are its
// row masks, a twelfth of the reference's: exactly that, so that an overrun would show).
SpeckleScratch make_scratch(int w, int h, int (*label_width)(int) = &reference::speckle_label_width) {
  SpeckleScratch s;
  s.label.reset(label_width(w), h);
  s.stack = detail::allocate_aligned<std::int32_t>(static_cast<std::size_t>(w) * h);
  return s;
}

// Disparity-like map for speckle removal: tiles of nearly constant value (neighbours within the
// 16 of max_diff, tiles far apart), dotted with small islands of another value and with invalid
// pixels, so that component sizes spread over 1 .. a few hundred pixels.
Plane<std::int16_t> speckle_map(int w, int h, std::uint32_t seed, int tile, double invalid_fraction) {
  Plane<std::int16_t> p(w, h);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> base(-40, 40), noise(0, 8), island_size(1, 12), step(0, 3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int tw = (w + tile - 1) / tile, th = (h + tile - 1) / tile;
  std::vector<int> tile_value(static_cast<std::size_t>(tw) * th);
  for (int& v : tile_value) v = 32 * base(rng);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) p.at(x, y) = static_cast<std::int16_t>(tile_value[(y / tile) * tw + x / tile] + noise(rng));
  const int islands = w * h / 40;
  for (int i = 0; i < islands; ++i) {
    int x = static_cast<int>(u(rng) * w), y = static_cast<int>(u(rng) * h);
    const std::int16_t v = static_cast<std::int16_t>(p.at(x, y) + 200);
    for (int n = island_size(rng); n > 0; --n) {
      p.at(x, y) = v;
      switch (step(rng)) {
        case 0: x = std::min(x + 1, w - 1); break;
        case 1: x = std::max(x - 1, 0); break;
        case 2: y = std::min(y + 1, h - 1); break;
        default: y = std::max(y - 1, 0); break;
      }
    }
  }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (u(rng) < invalid_fraction) p.at(x, y) = kInvalid;
  return p;
}

// ------------------------------------------------------------------------------------------
// Known answers of the reference.

TEST(RefineReference, Median3x3KnownAnswer) {
  // An impulse (99) disappears, clamped borders repeat the edge, invalid pixels count as the
  // smallest value: a window with five of them is invalid, one with three takes a low value.
  const auto src = make_map(5, 5, {10, 10, 10, 10, 10,  //
                                   10, 99, 10, 20, 20,  //
                                   10, 10, I, 20, 20,   //
                                   I, I, I, 20, 20,     //
                                   30, 30, I, 20, 20});
  Plane<std::int16_t> dst(5, 5);
  reference::median_filter(src, 3, dst);
  const std::vector<std::int16_t> expected = {10, 10, 10, 10, 10,  //
                                              10, 10, 10, 10, 20,  //
                                              10, 10, 10, 20, 20,  //
                                              10, I, 10, 20, 20,   //
                                              30, I, 20, 20, 20};
  EXPECT_EQ(pixels(dst), expected);
}

TEST(RefineReference, FillKnownAnswers) {
  for (const FillCase& c : fill_known_answers()) {
    Plane<std::int16_t> p(static_cast<int>(c.in.size()), 1);
    std::copy(c.in.begin(), c.in.end(), p.row(0));
    reference::fill_invalid(p, c.mode);
    EXPECT_EQ(pixels(p), c.out) << "mode " << static_cast<int>(c.mode) << ", case starting " << c.in[0];
  }
}

TEST(RefineReference, LrCheckKnownAnswer) {
  const auto left = make_map(8, 1, {I, 16, 16, 32, 40, 24, 8, 200});
  const auto right = make_map(8, 1, {16, 16, 32, 24, 48, I, 40, 16});
  Plane<std::int16_t> dst(8, 1);
  // Left reference: x matches x - round(d). x = 4 disagrees by 24, x = 6 meets an invalid pixel,
  // x = 7 points outside the image.
  reference::lr_check(left, right, -1, 16, dst);
  EXPECT_EQ(pixels(dst), (std::vector<std::int16_t>{I, 16, 16, 32, I, 24, I, I}));
  reference::lr_check(left, right, -1, 0, dst);
  EXPECT_EQ(pixels(dst), (std::vector<std::int16_t>{I, 16, 16, I, I, 24, I, I}));
  // Right reference: x matches x + round(d).
  reference::lr_check(right, left, +1, 16, dst);
  EXPECT_EQ(pixels(dst), (std::vector<std::int16_t>{16, 16, 32, 24, I, I, I, I}));
  // Negative disparities round half up: -8 -> 0 px, -9 and -24 -> -1 px.
  const auto neg = make_map(4, 1, {-9, -8, -24, 0});
  const auto neg_other = make_map(4, 1, {5, -9, 0, -20});
  Plane<std::int16_t> neg_dst(4, 1);
  reference::lr_check(neg, neg_other, -1, 16, neg_dst);
  EXPECT_EQ(pixels(neg_dst), (std::vector<std::int16_t>{-9, -8, -24, I}));
}

TEST(RefineReference, SpeckleKnownAnswer) {
  // A 3-pixel region (80, 96, 88: neighbours within 16) and a single pixel 112 that touches it
  // only diagonally, in a background of 0 with one invalid pixel.
  const auto map = make_map(6, 5, {0, 0, 0,  0,   0, 0,  //
                                   0, 80, 96, 0,  0, 0,  //
                                   0, 88, 0,  112, I, 0,  //
                                   0, 0,  0,  0,   0, 0,  //
                                   0, 0,  0,  0,   0, 0});
  SpeckleScratch scratch = make_scratch(6, 5);
  const auto run = [&](int max_size) {
    Plane<std::int16_t> p = copy_of(map);
    reference::remove_speckles(p, max_size, 16, scratch);
    return p;
  };
  const auto at_4 = run(4), at_3 = run(3), at_1 = run(1);
  for (auto [x, y] : {std::pair{1, 1}, {2, 1}, {1, 2}, {3, 2}}) EXPECT_EQ(at_4.at(x, y), I) << x << ", " << y;
  EXPECT_EQ(count_invalid(at_4), 5);
  EXPECT_EQ(at_3.at(1, 1), 80);
  EXPECT_EQ(at_3.at(2, 1), 96);
  EXPECT_EQ(at_3.at(1, 2), 88);
  EXPECT_EQ(at_3.at(3, 2), I);
  EXPECT_EQ(count_invalid(at_3), 2);
  EXPECT_EQ(pixels(at_1), pixels(map));
}

// ------------------------------------------------------------------------------------------
// cpu == reference.

// The partners on the grid as the parameter describes them, written apart from both backends:
// the even rows and columns as a half-size map, its median, each of its pixels over 2 x 2.
Plane<std::int16_t> grid_partners_by_definition(const Plane<std::int16_t>& right, int k) {
  const int w = right.width(), h = right.height();
  Plane<std::int16_t> grid((w + 1) / 2, (h + 1) / 2), median((w + 1) / 2, (h + 1) / 2), out(w, h);
  for (int j = 0; j < grid.height(); ++j)
    for (int i = 0; i < grid.width(); ++i) grid.at(i, j) = right.at(2 * i, 2 * j);
  if (k > 0) reference::median_filter(grid, k, median);
  const Plane<std::int16_t>& m = k > 0 ? median : grid;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out.at(x, y) = m.at(x / 2, y / 2);
  return out;
}

TEST(RefineReference, GridPartnerKnownAnswer) {
  // 5 x 3: grid columns 0, 2, 4 of rows 0 and 2 (a 3 x 2 grid); odd columns and row 1 are never
  // read.
  const auto right = make_map(5, 3, {10, 99, 20, 99, 30,  //
                                     99, 99, 99, 99, 99,  //
                                     40, 99, I, 99, 60});
  Plane<std::int16_t> partner(5, 3);
  MatchScratch none;
  reference::grid_partner(right, 0, none, partner);
  EXPECT_EQ(pixels(partner), (std::vector<std::int16_t>{10, 10, 20, 20, 30,  //
                                                        10, 10, 20, 20, 30,  //
                                                        40, 40, I, I, 60}));
  // 3 x 3 median on the 3 x 2 grid (10 20 30 / 40 I 60), clamped: grid (0, 0) sees 10 10 20 twice
  // and 40 40 I -> 10; (1, 0) sees 10 20 30 twice and 40 I 60 -> 20; (0, 1) sees 10 10 20 and
  // 40 40 I twice -> 20; (1, 1) sees 10 20 30 and 40 I 60 twice -> 30.
  reference::grid_partner(right, 3, none, partner);
  EXPECT_EQ(pixels(partner), (std::vector<std::int16_t>{10, 10, 20, 20, 30,  //
                                                        10, 10, 20, 20, 30,  //
                                                        20, 20, 30, 30, 30}));
}

TEST(RefineReference, GridPartnerIsTheMedianOnTheGrid) {
  std::uint32_t seed = 1700;
  for (const auto& w_h : awkward_sizes()) {
    for (const MapKind& kind : kMapKinds) {
      const auto right = random_disparity(w_h.first, w_h.second, ++seed, -400, 600, kind.invalid, kind.whole);
      for (int k : {0, 3, 5}) {
        Plane<std::int16_t> partner = random_disparity(w_h.first, w_h.second, seed + 7, 0, 9);
        MatchScratch none;
        reference::grid_partner(right, k, none, partner);
        ASSERT_EQ(first_difference(grid_partners_by_definition(right, k), partner), "")
            << w_h.first << "x" << w_h.second << " k " << k << " invalid " << kind.invalid;
      }
    }
  }
}

TEST(RefineCpu, GridPartnerMatchesReference) {
  std::uint32_t seed = 1800;
  for (const auto& w_h : awkward_sizes()) {
    const int w = w_h.first, h = w_h.second;
    for (const MapKind& kind : kMapKinds) {
      const auto right = random_disparity(w, h, ++seed, -400, 600, kind.invalid, kind.whole);
      for (int k : {0, 3, 5}) {
        Plane<std::int16_t> expected(w, h), actual(w, h);
        MatchScratch none;
        reference::grid_partner(right, k, none, expected);
        // Slices of an odd size: the stage aligns each thread's slice itself.
        MatchScratch scratch = thread_scratch<MatchScratch>(cpu::grid_partner_scratch_bytes(w) + 8, 2);
        for_each_target_and_threads([&](const std::string& where) {
          cpu::grid_partner(right, k, scratch, actual);
          ASSERT_EQ(first_difference(expected, actual), "")
              << w << "x" << h << " k " << k << " invalid " << kind.invalid << " on " << where;
        });
      }
    }
  }
}

TEST(RefineCpu, MedianFilterMatchesReference) {
  std::uint32_t seed = 100;
  for (const auto& w_h : awkward_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (const MapKind& kind : kMapKinds) {
      const auto src = random_disparity(w, h, ++seed, -400, 600, kind.invalid, kind.whole);
      for (int k : {3, 5}) {
        Plane<std::int16_t> expected(w, h), actual(w, h);
        reference::median_filter(src, k, expected);
        for_each_target_and_threads([&](const std::string& where) {
          cpu::median_filter(src, k, actual);
          ASSERT_EQ(first_difference(expected, actual), "")
              << w << "x" << h << " k " << k << " invalid " << kind.invalid << " on " << where;
        });
      }
    }
  }
}

TEST(RefineCpu, MedianFilterMatchesReferenceWithManyTies) {
  // Two values and invalid pixels: windows full of ties exercise every comparator of the networks.
  for (double invalid : {0.0, 0.3}) {
    const auto src = random_disparity(631, 479, invalid > 0 ? 7 : 8, 0, 1, invalid);
    for (int k : {3, 5}) {
      Plane<std::int16_t> expected(631, 479), actual(631, 479);
      reference::median_filter(src, k, expected);
      for_each_target_and_threads([&](const std::string& where) {
        cpu::median_filter(src, k, actual);
        ASSERT_EQ(first_difference(expected, actual), "") << "k " << k << " on " << where;
      });
    }
  }
}

TEST(RefineCpu, LrCheckMatchesReference) {
  std::uint32_t seed = 200;
  for (const auto& w_h : awkward_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (const MapKind& kind : kMapKinds) {
      const auto [src, other, narrow, narrow_other] = lr_check_maps(w, h, seed, kind);
      for (int dir : {-1, +1}) {
        for (int threshold : {0, 16, 32}) {
          for (const auto& a_b : {std::pair{&src, &other}, {&narrow, &narrow_other}}) {
            const auto a = a_b.first;
            const auto b = a_b.second;
            Plane<std::int16_t> expected(w, h), actual(w, h);
            reference::lr_check(*a, *b, dir, threshold, expected);
            for_each_target_and_threads([&](const std::string& where) {
              cpu::lr_check(*a, *b, dir, threshold, actual);
              ASSERT_EQ(first_difference(expected, actual), "") << w << "x" << h << " dir " << dir
                                                                << " threshold " << threshold << " on " << where;
            });
          }
        }
      }
    }
  }
}

// Vectors whose rounded disparities span 2 to 30 values (the shifted-load path up to its limit of
// 32, and beyond it) and first vectors of a row whose partners lie before column 0 (read from the
// copy behind invalid entries), with maps wider than that copy and narrower.
TEST(RefineCpu, LrCheckMatchesReferenceOnWideSpansAndRowStarts) {
  std::uint32_t seed = 900;
  for (const auto& w_h : std::vector<std::pair<int, int>>{{640, 6}, {200, 5}, {97, 4}, {33, 3}, {130, 2}}) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (int span : {2, 9, 17, 30, 40}) {
      for (int offset : {0, 50, 70}) {
        const auto a = random_disparity(w, h, ++seed, 16 * offset, 16 * (offset + span) - 1, 0.05);
        const auto b = random_disparity(w, h, ++seed, 16 * offset, 16 * (offset + span) - 1, 0.05);
        for (int dir : {-1, +1}) {
          Plane<std::int16_t> expected(w, h), actual(w, h);
          reference::lr_check(a, b, dir, 16, expected);
          for_each_target_and_threads([&](const std::string& where) {
            cpu::lr_check(a, b, dir, 16, actual);
            ASSERT_EQ(first_difference(expected, actual), "")
                << w << "x" << h << " span " << span << " offset " << offset << " dir " << dir << " on " << where;
          });
        }
      }
    }
  }
}

TEST(RefineCpu, LrCheckMatchesReferenceOnSmoothMaps) {
  std::uint32_t seed = 700;
  auto sizes = awkward_sizes();
  sizes.push_back({300, 2});
  for (const auto& w_h : sizes) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (const auto& base_step : kLrCheckMapShapes) {
      const auto base = base_step.first;
      const auto step = base_step.second;
      const auto a = smooth_disparity(w, h, ++seed, base, step, 9);
      const auto b = smooth_disparity(w, h, ++seed, base, step, 9);
      for (int dir : {-1, +1})
        for (int threshold : {0, 16}) {
          Plane<std::int16_t> expected(w, h), actual(w, h);
          reference::lr_check(a, b, dir, threshold, expected);
          if (w * h > 1000 && base == 16 * 3) {
            const int kept = w * h - count_invalid(expected);
            ASSERT_GT(kept, 0) << "a vacuous case";
          }
          for_each_target_and_threads([&](const std::string& where) {
            cpu::lr_check(a, b, dir, threshold, actual);
            ASSERT_EQ(first_difference(expected, actual), "")
                << w << "x" << h << " base " << base << " dir " << dir << " threshold " << threshold << " on " << where;
          });
        }
    }
  }
}

TEST(RefineCpu, LrCheckKeepsAndRejectsOnLargeMaps) {
  // Guards the comparison above against a degenerate outcome (everything invalid or kept).
  const auto src = random_disparity(631, 479, 5, 0, 40, 0.1);
  const auto other = random_disparity(631, 479, 6, 0, 40, 0.1);
  Plane<std::int16_t> actual(631, 479);
  cpu::lr_check(src, other, -1, 16, actual);
  const int invalid = count_invalid(actual);
  EXPECT_GT(invalid, 631 * 479 / 10);
  EXPECT_LT(invalid, 631 * 479 / 2);
}

TEST(RefineCpu, RemoveSpecklesMatchesReference) {
  std::uint32_t seed = 300;
  for (const auto& w_h : awkward_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    SpeckleScratch scratch = make_scratch(w, h), cpu_scratch = make_scratch(w, h, &cpu::speckle_label_width);
    for (const MapKind& kind : kMapKinds) {
      const Plane<std::int16_t> maps[] = {
          speckle_map(w, h, ++seed, 8, kind.invalid),
          speckle_map(w, h, ++seed, 16, kind.invalid),
          // Noise in a narrow range: percolation-like components of every shape.
          random_disparity(w, h, ++seed, 0, 48, kind.invalid, kind.whole),
      };
      for (const auto& map : maps) {
        for (int max_size : {1, 2, 10, 100}) {
          Plane<std::int16_t> expected = copy_of(map);
          reference::remove_speckles(expected, max_size, 16, scratch);
          if (w * h > 1000 && kind.invalid < 0.5 && max_size >= 10)
            EXPECT_GT(count_invalid(expected), count_invalid(map)) << w << "x" << h << " size " << max_size;
          for_each_target_and_threads([&](const std::string& where) {
            Plane<std::int16_t> actual = copy_of(map);
            // The scratch holds whatever earlier calls left in it, as in the driver.
            cpu::remove_speckles(actual, max_size, 16, cpu_scratch);
            ASSERT_EQ(first_difference(expected, actual), "")
                << w << "x" << h << " size " << max_size << " invalid " << kind.invalid << " on " << where;
          });
        }
      }
    }
  }
}

TEST(RefineCpu, RemoveSpecklesWithSmallerMapThanScratch) {
  // The driver sizes the scratch for the finest level and reuses it at coarser ones.
  SpeckleScratch scratch = make_scratch(640, 480), cpu_scratch = make_scratch(640, 480, &cpu::speckle_label_width);
  for (const auto& w_h : {std::pair{320, 240}, {161, 121}, {33, 7}}) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    const auto map = speckle_map(w, h, 77 + w, 8, 0.05);
    Plane<std::int16_t> expected = copy_of(map), actual = copy_of(map);
    reference::remove_speckles(expected, 50, 16, scratch);
    cpu::remove_speckles(actual, 50, 16, cpu_scratch);
    EXPECT_EQ(first_difference(expected, actual), "") << w << "x" << h;
  }
}

TEST(RefineCpu, RemoveSpecklesWithUnusualThresholds) {
  const auto map = speckle_map(65, 33, 5, 8, 0.1);
  SpeckleScratch scratch = make_scratch(65, 33), cpu_scratch = make_scratch(65, 33, &cpu::speckle_label_width);
  for (int max_diff : {-1, 0, 1000, 70000}) {
    for (int max_size : {0, 2, 5000}) {
      Plane<std::int16_t> expected = copy_of(map), actual = copy_of(map);
      reference::remove_speckles(expected, max_size, max_diff, scratch);
      cpu::remove_speckles(actual, max_size, max_diff, cpu_scratch);
      EXPECT_EQ(first_difference(expected, actual), "") << "max_diff " << max_diff << " size " << max_size;
    }
  }
}

// refine_left_map: the stages one by one on whole maps (written here, apart from both backends).
Plane<std::int16_t> refined_left_by_stages(const Plane<std::int16_t>& left, const Plane<std::int16_t>& right,
                                           const LeftMapRefinement& c) {
  const int w = left.width(), h = left.height();
  Plane<std::int16_t> l = copy_of(left), r = copy_of(right), checked(w, h), out(w, h);
  if (c.median_size > 0) {
    reference::median_filter(left, c.median_size, l);
    reference::median_filter(right, c.median_size, r);
  }
  if (c.grid) r = grid_partners_by_definition(right, c.median_size);
  reference::lr_check(l, r, -1, c.threshold_q4, checked);
  reference::fill_invalid(checked, c.fill);
  if (c.post_median_size == 0) return checked;
  reference::median_filter(checked, c.post_median_size, out);
  return out;
}

// Sizes around the strips of 16 rows and their halos (1 or 2 rows), and the awkward ones.
std::vector<std::pair<int, int>> refine_left_map_sizes() {
  auto sizes = awkward_sizes();
  sizes.insert(sizes.end(), {{50, 15}, {50, 16}, {50, 17}, {40, 18}, {40, 31}, {37, 32}, {37, 33}, {300, 34}});
  return sizes;
}

const LeftMapRefinement kLeftMapRefinements[] = {
    {3, 16, FillMode::NearestLower, 3},  // realtime's
    {0, 16, FillMode::NearestLower, 3}, {5, 0, FillMode::Nearest, 5}, {3, 32, FillMode::None, 0},
    {0, 16, FillMode::NearestLower, 0}, {5, 16, FillMode::NearestLower, 3}, {3, 16, FillMode::Nearest, 5},
    {0, 48, FillMode::None, 5},
    // The check on the right map's grid: realtime's, and without a median.
    {3, 16, FillMode::NearestLower, 3, true}, {0, 16, FillMode::NearestLower, 0, true},
    {5, 32, FillMode::Nearest, 5, true}};

std::string describe(const LeftMapRefinement& c) {
  return "median " + std::to_string(c.median_size) + " threshold " + std::to_string(c.threshold_q4) + " fill " +
         std::to_string(static_cast<int>(c.fill)) + " post " + std::to_string(c.post_median_size) +
         (c.grid ? " grid" : "");
}

// The reference's refine_left_map is the stages in order, whatever its planes hold before, for
// every combination of medians (each path through its planes).
TEST(RefineReference, RefineLeftMapIsTheStagesInOrder) {
  std::uint32_t seed = 1300;
  for (const auto& w_h : refine_left_map_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    const auto left = smooth_disparity(w, h, ++seed, 16 * 3, 13, 9);
    const auto right = smooth_disparity(w, h, ++seed, 16 * 3, 13, 9);
    for (const LeftMapRefinement& c : kLeftMapRefinements) {
      const auto expected = refined_left_by_stages(left, right, c);
      Plane<std::int16_t> l = copy_of(left), r = copy_of(right), spare = random_disparity(w, h, 1, 0, 9),
                          out = random_disparity(w, h, 2, 0, 9);
      MatchScratch none;
      reference::refine_left_map(l, r, c, none, spare, out);
      ASSERT_EQ(first_difference(expected, out), "") << w << "x" << h << " " << describe(c);
    }
  }
}

TEST(RefineCpu, RefineLeftMapMatchesTheStages) {
  std::uint32_t seed = 1400;
  for (const auto& w_h : refine_left_map_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    // Maps that agree often (the same shape) and random ones that seldom do, with invalid pixels.
    const auto pair_of = [&](auto make) {
      auto left = make(seed + 1);
      auto right = make(seed + 2);
      seed += 2;
      return std::pair{std::move(left), std::move(right)};
    };
    std::vector<std::pair<Plane<std::int16_t>, Plane<std::int16_t>>> pairs;
    pairs.push_back(pair_of([&](std::uint32_t s) { return smooth_disparity(w, h, s, 16 * 3, 13, 9); }));
    pairs.push_back(pair_of([&](std::uint32_t s) { return smooth_disparity(w, h, s, 16 * 20, 7, 9); }));
    pairs.push_back(pair_of([&](std::uint32_t s) { return random_disparity(w, h, s, 0, 40, 0.3); }));
    for (const auto& left_right : pairs) {
      const auto& left = left_right.first;
      const auto& right = left_right.second;
      for (const LeftMapRefinement& c : kLeftMapRefinements) {
        const auto expected = refined_left_by_stages(left, right, c);
        // Slices of an odd size: the stage aligns each thread's slice itself.
        MatchScratch scratch = thread_scratch<MatchScratch>(cpu::refine_left_map_scratch_bytes(w) + 8, 2);
        for_each_target_and_threads([&](const std::string& where) {
          Plane<std::int16_t> l = copy_of(left), r = copy_of(right), spare(w, h), out(w, h);
          cpu::refine_left_map(l, r, c, scratch, spare, out);
          ASSERT_EQ(first_difference(expected, out), "") << w << "x" << h << " " << describe(c) << " on " << where;
        });
      }
    }
  }
}

TEST(RefineCpu, RefineLeftMapChecksAndFills) {
  // Guards the comparison above against a degenerate case: the check rejects a share of the
  // pixels of realtime's configuration, and the fill leaves none invalid.
  const auto left = smooth_disparity(631, 479, 31, 16 * 3, 13, 9);
  const auto right = smooth_disparity(631, 479, 32, 16 * 3, 13, 9);
  const LeftMapRefinement c = kLeftMapRefinements[0];
  Plane<std::int16_t> checked(631, 479), l = copy_of(left), r = copy_of(right), spare(631, 479), out(631, 479);
  reference::lr_check(left, right, -1, c.threshold_q4, checked);
  const int rejected = count_invalid(checked);
  EXPECT_GT(rejected, 631 * 479 / 10);
  EXPECT_LT(rejected, 631 * 479 * 9 / 10);
  MatchScratch scratch = thread_scratch<MatchScratch>(cpu::refine_left_map_scratch_bytes(631), 2);
  cpu::refine_left_map(l, r, c, scratch, spare, out);
  EXPECT_EQ(count_invalid(out), 0);
}

TEST(RefineCpu, FillInvalidMatchesReference) {
  std::uint32_t seed = 400;
  for (const auto& w_h : awkward_sizes()) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    // 85 % invalid adds runs longer than the short-run path (8 pixels) takes.
    for (double invalid : {0.0, 0.1, 0.6, 0.85, 1.0}) {
      const auto map = random_disparity(w, h, ++seed, -400, 600, invalid, invalid == 0.6);
      for (FillMode mode : {FillMode::None, FillMode::Nearest, FillMode::NearestLower}) {
        Plane<std::int16_t> expected = copy_of(map);
        reference::fill_invalid(expected, mode);
        for_each_target_and_threads([&](const std::string& where) {
          Plane<std::int16_t> actual = copy_of(map);
          cpu::fill_invalid(actual, mode);
          ASSERT_EQ(first_difference(expected, actual), "") << w << "x" << h << " mode " << static_cast<int>(mode)
                                                            << " invalid " << invalid << " on " << where;
        });
      }
    }
  }
}

// Rows wider than the AVX-512 fill's blocks of 1024 columns (runs that cross them, values carried
// over many all-invalid vectors), and the values next to INT16_MAX, which that fill takes for
// "no value" and leaves to the run-by-run path.
TEST(RefineCpu, FillInvalidMatchesReferenceOnWideRowsAndExtremeValues) {
  std::uint32_t seed = 1500;
  for (const auto& w_h : std::vector<std::pair<int, int>>{{1023, 3}, {1024, 3}, {1025, 3}, {2049, 2}, {3000, 2}}) {
    const auto w = w_h.first;
    const auto h = w_h.second;
    for (double invalid : {0.1, 0.85, 0.99}) {
      auto map = random_disparity(w, h, ++seed, -400, 600, invalid);
      // Row 0: two valid pixels, far apart across a block boundary.
      for (int x = 0; x < w; ++x) map.at(x, 0) = x == 5 ? 77 : x == w - 20 ? -33 : kInvalid;
      for (FillMode mode : {FillMode::Nearest, FillMode::NearestLower}) {
        Plane<std::int16_t> expected = copy_of(map);
        reference::fill_invalid(expected, mode);
        for_each_target_and_threads([&](const std::string& where) {
          Plane<std::int16_t> actual = copy_of(map);
          cpu::fill_invalid(actual, mode);
          ASSERT_EQ(first_difference(expected, actual), "") << w << "x" << h << " invalid " << invalid << " on " << where;
        });
      }
    }
  }
  for (std::int16_t top : {std::int16_t{INT16_MAX}, std::int16_t{INT16_MAX - 1}}) {
    auto map = random_disparity(100, 4, 1600, 32700, 32767, 0.5);
    map.at(3, 1) = top;
    Plane<std::int16_t> expected = copy_of(map);
    reference::fill_invalid(expected, FillMode::NearestLower);
    for_each_target_and_threads([&](const std::string& where) {
      Plane<std::int16_t> actual = copy_of(map);
      cpu::fill_invalid(actual, FillMode::NearestLower);
      ASSERT_EQ(first_difference(expected, actual), "") << "top " << top << " on " << where;
    });
  }
}

}  // namespace
}  // namespace mctstereo::test
