// opencl::match against reference::match, bit for bit: awkward sizes and a 640-wide band, both
// views, every SHD window, 1 to 3 census words, negative, nearly image-wide and out-of-image
// ranges, the search rule around coarse priors (ceil and floor half sizes, invalid pixels, radius
// 0..4), sub-pixel, uniqueness, both popcount forms and the work layouts of GPUs and CPU devices.
// Each run also checks that the kernel writes the image pixels and nothing else of the output
// buffer.
#include <algorithm>
#include <vector>

#include "opencl/stages.hpp"
#include "opencl_test_util.hpp"
#include "test_util.hpp"

namespace mctstereo::detail::opencl {
// match() with the work layout of a GPU or of a CPU device, whatever the device is (match.cpp).
void match_with_layout(Runtime& rt, const DeviceCodes& ref, const DeviceCodes& other,
                       const DevicePlane<std::int16_t>* prior, int dmin, int dmax, int radius,
                       const MatchConfig& config, Popcount popcount, bool gpu_layout,
                       DevicePlane<std::int16_t>& disparity, DevicePlane<std::uint8_t>* margin,
                       const DeviceTemporal* temporal);
}  // namespace mctstereo::detail::opencl

namespace mctstereo::test {
namespace {

using detail::CensusCodes;
using detail::kInvalid;
using detail::MatchConfig;
using detail::opencl::DeviceCodes;
using detail::opencl::DevicePlane;
using detail::opencl::Popcount;
using detail::opencl::Runtime;

/// Host codes (reference::census_transform) and the same codes on the device.
struct Codes {
  CensusCodes host;
  DeviceCodes device;
};

Codes census(Runtime& rt, const Plane<std::uint8_t>& image, int window, CensusKind kind) {
  Codes c;
  c.host = reference_census(image, window, kind);
  c.device.words = c.host.words;
  for (int k = 0; k < c.host.words; ++k) {
    c.device.plane[k].reset(rt, image.width(), image.height());
    detail::opencl::upload(rt, c.host.plane[k], c.device.plane[k]);
  }
  return c;
}

struct Views {
  Codes left, right;
  const Codes& ref(int dir) const { return dir < 0 ? left : right; }
  const Codes& other(int dir) const { return dir < 0 ? right : left; }
};

Views views(Runtime& rt, const ShiftedPair& pair, int window, CensusKind kind = CensusKind::Census) {
  return {census(rt, pair.left, window, kind), census(rt, pair.right, window, kind)};
}

/// The search rule's inputs: prior null = the whole range [dmin, dmax] everywhere; a temporal
/// prior (used with a prior) when temporal.on().
struct Search {
  const Plane<std::int16_t>* prior = nullptr;
  int dmin = 0, dmax = 0, radius = 0;
  detail::TemporalPrior temporal = {};
};

/// A host plane on the device.
template <typename T>
DevicePlane<T> on_device(Runtime& rt, const Plane<T>& host) {
  DevicePlane<T> p;
  p.reset(rt, host.width(), host.height());
  detail::opencl::upload(rt, host, p);
  return p;
}

struct Stats {
  long valid = 0, fractional = 0;
};

constexpr std::int16_t kSentinel = 12345;

enum class Layout { Device, Gpu, Cpu };

/// Runs opencl::match (with the device's layout or a given one) and compares with reference::match, the
/// left view's winners' margins too (so that kernels with and without them both run); also checks that
/// the padding of the output rows keeps its sentinel. Returns counts of the reference
/// output so that callers can check that the case was not vacuous.
Stats expect_same(Runtime& rt, const Views& v, const Search& s, const MatchConfig& config,
                  Popcount popcount = Popcount::Builtin, Layout layout = Layout::Device) {
  const CensusCodes& ref = v.ref(config.dir).host;
  const int w = ref.plane[0].width(), h = ref.plane[0].height();
  detail::MatchScratch scratch;
  scratch.bytes_per_thread = detail::reference::match_scratch_bytes(w, std::max(s.dmax - s.dmin + 1, 1), 0);
  scratch.data = detail::allocate_aligned<std::uint8_t>(scratch.bytes_per_thread);
  Plane<std::int16_t> expected(w, h);
  Plane<std::uint8_t> expected_margin(w, h);
  detail::SearchRanges ranges = detail::SearchRanges::around(s.prior, s.dmin, s.dmax, s.radius);
  ranges.temporal = s.temporal;
  detail::reference::match(ref, v.other(config.dir).host, ranges, config, scratch, expected, &expected_margin);
  Stats stats;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int value = expected.at(x, y);
      stats.valid += value != kInvalid;
      stats.fractional += value != kInvalid && (value & 15) != 0;
    }

  DevicePlane<std::int16_t> prior, out;
  if (s.prior != nullptr) {
    prior.reset(rt, s.prior->width(), s.prior->height());
    detail::opencl::upload(rt, *s.prior, prior);
  }
  out.reset(rt, w, h);
  std::vector<std::int16_t> buffer(out.bytes() / sizeof(std::int16_t), kSentinel);
  rt.queue().enqueueWriteBuffer(out.buffer, CL_TRUE, 0, out.bytes(), buffer.data());
  const DevicePlane<std::int16_t>* prior_arg = s.prior != nullptr ? &prior : nullptr;
  DevicePlane<std::uint8_t> margin;
  const bool with_margin = config.dir < 0 && w > 0 && h > 0;
  if (with_margin) margin.reset(rt, w, h);
  DevicePlane<std::uint8_t>* margin_arg = with_margin ? &margin : nullptr;
  DevicePlane<std::int16_t> previous;
  DevicePlane<std::uint8_t> image, previous_image;
  detail::opencl::DeviceTemporal temporal{&previous, &image, &previous_image, s.temporal.radius,
                                          s.temporal.threshold};
  if (s.temporal.on()) {
    previous = on_device(rt, *s.temporal.map);
    image = on_device(rt, *s.temporal.image);
    previous_image = on_device(rt, *s.temporal.previous_image);
  }
  const detail::opencl::DeviceTemporal* temporal_arg = s.temporal.on() ? &temporal : nullptr;
  if (layout == Layout::Device)
    detail::opencl::match(rt, v.ref(config.dir).device, v.other(config.dir).device, prior_arg, s.dmin, s.dmax,
                          s.radius, config, popcount, out, margin_arg, temporal_arg);
  else
    detail::opencl::match_with_layout(rt, v.ref(config.dir).device, v.other(config.dir).device, prior_arg, s.dmin,
                                      s.dmax, s.radius, config, popcount, layout == Layout::Gpu, out, margin_arg,
                                      temporal_arg);
  rt.queue().enqueueReadBuffer(out.buffer, CL_TRUE, 0, out.bytes(), buffer.data());

  Plane<std::int16_t> got(w, h);
  bool slack_kept = true;
  for (std::size_t i = 0; i < buffer.size(); ++i) {
    const int x = static_cast<int>(i % out.stride), y = static_cast<int>(i / out.stride);
    if (x < w && y < h)
      got.at(x, y) = buffer[i];
    else
      slack_kept = slack_kept && buffer[i] == kSentinel;
  }
  const std::string what = std::to_string(w) + "x" + std::to_string(h) + ", dir " + std::to_string(config.dir) +
                           ", a " + std::to_string(config.shd_window) + ", words " + std::to_string(ref.words) +
                           ", subpixel " + std::to_string(config.subpixel) + ", uniqueness " +
                           std::to_string(config.uniqueness_ratio) + ", range " + std::to_string(s.dmin) + ".." +
                           std::to_string(s.dmax) + (s.prior ? ", prior radius " + std::to_string(s.radius) : "") +
                           (s.temporal.on() ? ", temporal radius " + std::to_string(s.temporal.radius) : "") +
                           (popcount == Popcount::Swar ? ", SWAR" : "") +
                           (layout == Layout::Gpu ? ", GPU layout" : layout == Layout::Cpu ? ", CPU layout" : "");
  EXPECT_EQ(first_difference(expected, got), "") << what;
  EXPECT_TRUE(slack_kept) << "wrote outside the image: " << what;
  if (with_margin) {
    Plane<std::uint8_t> got_margin(w, h);
    detail::opencl::download(rt, margin, got_margin);
    EXPECT_EQ(first_difference(expected_margin, got_margin), "") << "margins, " << what;
  }
  return stats;
}

TEST(OpenclMatch, AwkwardSizesBothViewsFullRange) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 100;
  for (auto [w, h] : awkward_sizes()) {
    if (w * h > 100000) w = 181, h = 67;  // a modest odd size instead of the large one
    const Views v = views(*rt, shifted_pair(w, h, ++seed, 3), 5);
    for (int dir : {-1, +1}) {
      const Stats s = expect_same(*rt, v, {nullptr, 0, std::min(w + 2, 24), 0}, {dir, 5, dir < 0, dir < 0 ? 15 : 0});
      EXPECT_GT(s.valid, 0) << w << "x" << h;
    }
  }
}

TEST(OpenclMatch, BandOf640ColumnsFullSearchAndAroundAPrior) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 640, h = 100;
  const Views v = views(*rt, shifted_pair(w, h, 11, 9), 5, CensusKind::ModifiedCensus);
  Stats s = expect_same(*rt, v, {nullptr, 0, 63, 0}, {-1, 5, false, 0});
  EXPECT_GT(s.valid, w * h * 9 / 10);
  // The finest level's case: a whole-pixel prior of half size, radius 1, sub-pixel and uniqueness.
  const Plane<std::int16_t> prior = random_disparity(w / 2, h / 2, 12, 16 * 2, 16 * 7, 0.1, true);
  for (int dir : {-1, +1}) {
    s = expect_same(*rt, v, {&prior, 0, 63, 1}, {dir, 5, true, 15});
    EXPECT_GT(s.valid, w * h / 4);
    EXPECT_GT(s.fractional, 0);
  }
}

TEST(OpenclMatch, EveryShdWindowCensusWindowAndWordCount) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 70, h = 19;
  // Census windows 3, 5, 7, 9 give 1, 1, 2, 3 words; every SHD window runs with each word count
  // at least once; sub-pixel and uniqueness vary along (each program is one build).
  struct Case {
    int census_window;
    CensusKind kind;
    std::vector<int> shd_windows;
  };
  const Case cases[] = {{5, CensusKind::Census, {1, 3, 5, 7, 9}},
                        {3, CensusKind::ModifiedCensus, {3}},
                        {7, CensusKind::ModifiedCensus, {1, 3, 9}},
                        {9, CensusKind::Census, {1, 5, 7}}};
  std::uint32_t seed = 300;
  for (const Case& c : cases) {
    const Views v = views(*rt, shifted_pair(w, h, ++seed, 6), c.census_window, c.kind);
    ASSERT_EQ(v.left.host.words, detail::census_words(c.census_window));
    for (int a : c.shd_windows) {
      const int dir = (a / 2) % 2 == 0 ? -1 : +1;
      const Stats s = expect_same(*rt, v, {nullptr, 0, 20, 0}, {dir, a, a != 1, a == 5 || a == 9 ? 15 : 0});
      EXPECT_GT(s.valid, w * h / 2);
    }
  }
}

TEST(OpenclMatch, BothPopcountForms) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 83, h = 29;
  const ShiftedPair pair = shifted_pair(w, h, 41, 5);
  for (int census_window : {5, 9}) {  // 1 and 3 words
    const Views v = views(*rt, pair, census_window);
    for (Popcount popcount : {Popcount::Builtin, Popcount::Swar}) {
      const Stats s = expect_same(*rt, v, {nullptr, -2, 17, 0}, {-1, 5, true, 15}, popcount);
      EXPECT_GT(s.valid, w * h / 2);
    }
  }
}

TEST(OpenclMatch, SubpixelAndUniquenessAllCombinations) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 90, h = 33;
  const Views v = views(*rt, shifted_pair(w, h, 21, 5), 5);
  long valid_without_uniqueness = 0;
  for (bool subpixel : {false, true})
    for (int uniqueness : {0, 15, 60}) {
      const Stats s = expect_same(*rt, v, {nullptr, 0, 15, 0}, {-1, 5, subpixel, uniqueness});
      EXPECT_GT(s.valid, 0);
      if (subpixel && uniqueness < 60) {
        EXPECT_GT(s.fractional, 0);
      }
      if (!subpixel) {
        EXPECT_EQ(s.fractional, 0);
      }
      if (uniqueness == 0) valid_without_uniqueness = s.valid;
      if (uniqueness == 60) {
        EXPECT_LT(s.valid, valid_without_uniqueness);
      }
    }
}

TEST(OpenclMatch, RandomCodesWithManyTies) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // Uncorrelated noise: many candidates share the best cost, so the tie rule is exercised; a = 1
  // gives the smallest cost spread.
  const int w = 67, h = 13;
  const Views v{census(*rt, random_image(w, h, 5), 3, CensusKind::Census),
                census(*rt, random_image(w, h, 6), 3, CensusKind::Census)};
  for (const MatchConfig& config : {MatchConfig{-1, 1, false, 0}, MatchConfig{-1, 1, true, 15},
                                    MatchConfig{+1, 3, false, 15}, MatchConfig{-1, 3, true, 0}})
    expect_same(*rt, v, {nullptr, 0, 30, 0}, config);
}

TEST(OpenclMatch, NegativeMinimumDisparity) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 83, h = 27;
  const Views v = views(*rt, shifted_pair(w, h, 31, -7), 5, CensusKind::ModifiedCensus);
  for (int dir : {-1, +1}) {
    const Stats s = expect_same(*rt, v, {nullptr, -20, 10, 0}, {dir, 5, true, 15});
    EXPECT_GT(s.valid, w * h / 2);
  }
}

TEST(OpenclMatch, RangeNearlyAsWideAsTheImage) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const int w = 40, h = 11;
  const Views v = views(*rt, shifted_pair(w, h, 41, 9), 5);
  for (int dir : {-1, +1})
    for (int a : {1, 5, 9}) expect_same(*rt, v, {nullptr, 0, 38, 0}, {dir, a, true, 15});
}

TEST(OpenclMatch, RangesBeyondTheImageLeaveBorderPixelsInvalid) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // Only disparities 50..60 on a 56-wide image: most pixels have no candidate at all.
  const int w = 56, h = 9;
  const Views v = views(*rt, shifted_pair(w, h, 43, 2), 5);
  for (int dir : {-1, +1}) {
    const Stats s = expect_same(*rt, v, {nullptr, 50, 60, 0}, {dir, 5, true, 15});
    EXPECT_GT(s.valid, 0);
    EXPECT_LT(s.valid, w * h);
  }
  // No candidate anywhere: every pixel invalid.
  const Stats none = expect_same(*rt, v, {nullptr, 70, 80, 0}, {-1, 5, true, 15});
  EXPECT_EQ(none.valid, 0);
}

TEST(OpenclMatch, RangesByTheRuleAtAwkwardSizesAndPriorSizes) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // Priors of ceil(W / 2) x ceil(H / 2) (the pipeline's) and floor(W / 2) x floor(H / 2) (the last
  // column and row then read the clamped coarse pixel), 20 % invalid, radius 0..4.
  std::uint32_t seed = 900;
  int radius = 0;
  for (auto [w, h] : awkward_sizes()) {
    if (w * h > 100000) w = 181, h = 67;
    const Views v = views(*rt, shifted_pair(w, h, ++seed, 4), 5);
    for (bool ceil_half : {true, false}) {
      const int cw = ceil_half ? (w + 1) / 2 : w / 2, ch = ceil_half ? (h + 1) / 2 : h / 2;
      if (cw == 0 || ch == 0) continue;
      const Plane<std::int16_t> prior = random_disparity(cw, ch, ++seed, -16 * 3, 16 * 12, 0.2, true);
      for (int dir : {-1, +1})
        expect_same(*rt, v, {&prior, -4, 22, radius}, {dir, 5, true, dir < 0 ? 15 : 0});
      radius = (radius + 1) % 5;
    }
  }
}

TEST(OpenclMatch, SmoothPriorLikeTheFinestLevel) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // A slanted surface seen through the pyramid: prior = a plane at half resolution.
  const int w = 150, h = 60;
  const Views v = views(*rt, shifted_pair(w, h, 61, 8), 5);
  Plane<std::int16_t> prior((w + 1) / 2, (h + 1) / 2);
  for (int y = 0; y < prior.height(); ++y)
    for (int x = 0; x < prior.width(); ++x) prior.at(x, y) = static_cast<std::int16_t>(16 * (2 + x / 12 + y / 9));
  for (int radius : {1, 4}) {
    const Stats s = expect_same(*rt, v, {&prior, 0, 31, radius}, {-1, 5, true, 15});
    EXPECT_GT(s.valid, w * h / 2);
    EXPECT_GT(s.fractional, 0);
  }
}

TEST(OpenclMatch, GpuAndCpuWorkLayouts) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  // Both layouts on any device: 1 row per work-item with unrolled loops and 16 x 4 work-groups
  // (GPUs), 16 rows per work-item (CPU devices: a height that cuts the last strip short).
  const int w = 45, h = 23;
  const Views v = views(*rt, shifted_pair(w, h, 71, 4), 5);
  const Plane<std::int16_t> prior = random_disparity((w + 1) / 2, (h + 1) / 2, 72, 0, 16 * 10, 0.2, true);
  for (Layout layout : {Layout::Gpu, Layout::Cpu}) {
    expect_same(*rt, v, {nullptr, 0, 20, 0}, {-1, 5, true, 15}, Popcount::Builtin, layout);
    expect_same(*rt, v, {&prior, 0, 20, 2}, {+1, 5, true, 15}, Popcount::Builtin, layout);
  }
}

// The temporal prior: the previous frame's map near the coarse prior's values (so that its band
// often lies inside the coarse band), 20 % invalid, and gray images whose change straddles the
// threshold; awkward sizes, both views, radius 0..2, both work layouts.
TEST(OpenclMatch, TemporalPriorAtAwkwardSizesAndBothLayouts) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  std::uint32_t seed = 1300;
  int case_index = 0;
  long narrowed = 0;
  for (auto [w, h] : awkward_sizes()) {
    if (w * h > 100000) w = 181, h = 67;
    const int cw = (w + 1) / 2, ch = (h + 1) / 2;
    if (cw == 0 || ch == 0) continue;
    const Views v = views(*rt, shifted_pair(w, h, ++seed, 4), 5);
    const Plane<std::int16_t> prior = random_disparity(cw, ch, ++seed, 16 * 2, 16 * 8, 0.1, true);
    const Plane<std::int16_t> previous = random_disparity(w, h, ++seed, 16 * 3, 16 * 17, 0.2, false);
    const Plane<std::uint8_t> image = random_image(w, h, ++seed);
    Plane<std::uint8_t> previous_image(w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        previous_image.at(x, y) = static_cast<std::uint8_t>(std::clamp(image.at(x, y) + (x * 7 + y * 3) % 27 - 13, 0, 255));
    const int radius = case_index % 3;
    const Layout layout = case_index % 2 == 0 ? Layout::Gpu : Layout::Cpu;
    ++case_index;
    const detail::TemporalPrior temporal{&previous, &image, &previous_image, radius, 12};
    for (int dir : {-1, +1})
      expect_same(*rt, v, {&prior, -2, 22, 3, temporal}, {dir, 5, true, dir < 0 ? 15 : 0}, Popcount::Builtin, layout);
    // The case narrows some pixels (else it would test nothing of the rule).
    const detail::SearchRanges ranges = [&] {
      detail::SearchRanges r = detail::SearchRanges::around(&prior, -2, 22, 3);
      r.temporal = temporal;
      return r;
    }();
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const detail::Interval a = ranges.at(x, y), b = detail::search_range_at(&prior, -2, 22, 3, x, y);
        narrowed += a.hi - a.lo < b.hi - b.lo;
      }
  }
  EXPECT_GT(narrowed, 1000);
}

TEST(OpenclMatch, BadArgumentsAreClearErrors) {
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const Views v = views(*rt, shifted_pair(20, 6, 81, 2), 5);
  DevicePlane<std::int16_t> out;
  out.reset(*rt, 20, 6);
  const auto run = [&](const MatchConfig& config, DevicePlane<std::int16_t>& dst) {
    detail::opencl::match(*rt, v.left.device, v.right.device, nullptr, 0, 5, 0, config, Popcount::Builtin, dst);
  };
  EXPECT_THROW(run({-1, 4, false, 0}, out), std::invalid_argument);
  EXPECT_THROW(run({-1, 11, false, 0}, out), std::invalid_argument);
  EXPECT_THROW(run({0, 5, false, 0}, out), std::invalid_argument);
  DevicePlane<std::int16_t> small;
  small.reset(*rt, 19, 6);
  try {
    run({-1, 5, false, 0}, small);
    FAIL() << "a disparity map of the wrong size should be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("19 x 6"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mctstereo::test
