// The temporal prior (StereoParams::temporal, docs/PIPELINE.md "Temporal prior"): cpu equals
// reference frame after frame on every SIMD target; on synthetic sequences with exact ground truth
// (a still scene, a moving and approaching object, a cut to another scene) no frame is worse than
// the same frame matched alone by more than noise, and a still scene needs fewer candidates.
#include <cmath>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "pipeline_cases.hpp"
#include "synthetic_scene.hpp"

namespace mctstereo::test {
namespace {

constexpr int kW = 200, kH = 120;

// A slanted background (8 .. 14 px) and a square of 50 px at x = left with disparity d.
Scene square_scene(int left, double d, std::uint32_t noise_seed) {
  return make_scene(
      kW, kH,
      [=](int x, int y) { return x >= left && x < left + 50 && y >= 35 && y < 85 ? d : 8.0 + 6.0 * x / kW; }, 2.0, 7,
      noise_seed);
}

// Another scene: fronto-parallel steps over another texture.
Scene steps_scene(std::uint32_t noise_seed) {
  return make_scene(kW, kH, [](int x, int) { return x < 70 ? 30.0 : (x < 140 ? 18.0 : 5.0); }, 2.0, 99, noise_seed);
}

// The sequences: frames of a still scene (noise only changes), then the square moving right by
// 3 px and coming 1 px nearer per frame, then a cut to the steps.
std::vector<Scene> still_frames() { return {square_scene(60, 26, 1), square_scene(60, 26, 2), square_scene(60, 26, 3)}; }
std::vector<Scene> moving_then_cut_frames() {
  std::vector<Scene> frames;
  for (int i = 0; i < 5; ++i) frames.push_back(square_scene(60 + 3 * i, 26 + i, 10 + i));
  frames.push_back(steps_scene(20));
  frames.push_back(steps_scene(21));
  return frames;
}

StereoParams temporal(StereoParams p) {
  p.num_disparities = 48;
  p.temporal = true;
  return p;
}

// Fraction of the pixels with a correspondence whose disparity is invalid or more than 1 px off.
double bad_fraction(const Scene& s, const Matcher& m) {
  const CorrespondenceScore score = score_correspondences(s, m.disparity());
  return static_cast<double>(score.bad) / static_cast<double>(score.total);
}

std::vector<std::int16_t> match_alone(const Scene& s, const StereoParams& p) {
  StereoParams alone = p;
  alone.temporal = false;
  Matcher m(s.w, s.h, alone, Backend::Reference);
  m.compute(s.left_view(), s.right_view());
  return pixels(m.disparity_q4());
}

// Presets and variants with the prior on: SGM and box levels, one and both views matched with box
// sums, a negative range, a working scale.
std::vector<std::pair<std::string, StereoParams>> temporal_cases() {
  std::vector<std::pair<std::string, StereoParams>> cases = {{"balanced", temporal(preset("balanced"))},
                                                             {"quality", temporal(preset("quality"))}};
  StereoParams box = temporal(preset("realtime"));
  box.temporal_radius = 0;  // below realtime's radius 1: its finer levels take the prior
  cases.push_back({"realtime radius 0", box});
  StereoParams neg = temporal(preset("balanced"));
  neg.min_disparity = -6;
  neg.temporal_radius = 2;
  cases.push_back({"balanced negative min, radius 2", neg});
  StereoParams scaled = temporal(preset("quality"));
  scaled.working_scale = 2;
  cases.push_back({"quality working scale 2", scaled});
  // SGM at the finest level too (quality's finest level matches with box sums).
  cases.push_back({"SGM at every level", temporal(sgm_every_level())});
  return cases;
}

TEST(Temporal, CpuEqualsReferenceFrameAfterFrame) {
  const std::vector<std::pair<std::string, StereoParams>> cases = temporal_cases();
  std::vector<Scene> frames = moving_then_cut_frames();
  frames.insert(frames.begin() + 1, square_scene(60, 26, 30));  // a still frame too

  for (const auto& [name, p] : cases) {
    SCOPED_TRACE(name);
    Matcher ref(kW, kH, p, Backend::Reference);
    std::vector<Matcher> cpu;
    for (int threads : {1, 2}) {
      MatcherOptions o;
      o.threads = threads;
      cpu.emplace_back(kW, kH, p, Backend::Cpu, o);
    }
    for (std::size_t f = 0; f < frames.size(); ++f) {
      ref.compute(frames[f].left_view(), frames[f].right_view());
      EXPECT_EQ(ref.used_temporal_prior(), f > 0) << "frame " << f;
      for (std::size_t t = 0; t < cpu.size(); ++t) {
        cpu[t].compute(frames[f].left_view(), frames[f].right_view());
        EXPECT_EQ(describe_difference(pixels(cpu[t].disparity_q4()), pixels(ref.disparity_q4()), kW), "")
            << "frame " << f << ", threads " << t + 1;
      }
    }
    // After reset_temporal() a frame is matched alone.
    ref.reset_temporal();
    ref.compute(frames[2].left_view(), frames[2].right_view());
    EXPECT_FALSE(ref.used_temporal_prior());
    EXPECT_EQ(describe_difference(pixels(ref.disparity_q4()), match_alone(frames[2], p), kW), "");
  }
}

// Every pipeline case (awkward sizes, negative ranges, working scales, SGM and box levels) with the
// prior on, over frames whose left view stays while the disparities change (the prior is taken and
// wrong), then a cut: the cpu backend equals the reference frame after frame.
TEST(Temporal, CpuEqualsReferenceForEveryPipelineCase) {
  for (PipelineCase c : pipeline_cases()) {
    SCOPED_TRACE(c.name);
    c.params.temporal = true;
    c.params.temporal_radius = 0;  // narrows every level with a prior, realtime's radius 1 too
    const int d = c.max_disparity();
    std::vector<StereoPair> frames;
    frames.push_back(textured_pair(c.w, c.h, d, 11));
    frames.push_back(textured_pair(c.w, c.h, d, 11));
    frames.push_back(textured_pair(c.w, c.h, std::max(d - 3, 0), 11));
    frames.push_back(textured_pair(c.w, c.h, d, 12));
    MatcherOptions two;
    two.threads = 2;
    Matcher ref(c.w, c.h, c.params, Backend::Reference), cpu(c.w, c.h, c.params, Backend::Cpu, two);
    for (std::size_t f = 0; f < frames.size(); ++f) {
      ref.compute(frames[f].left_view(), frames[f].right_view());
      cpu.compute(frames[f].left_view(), frames[f].right_view());
      EXPECT_EQ(describe_difference(pixels(cpu.disparity_q4()), pixels(ref.disparity_q4()), c.w), "") << "frame " << f;
    }
  }
}

// The rule of one pixel, by hand: the previous frame's 3x3 holds 10 and 10.5 px (band [9, 12] with
// radius 1).
TEST(Temporal, BandRuleKnownAnswers) {
  Plane<std::int16_t> previous(5, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) previous.at(x, y) = 160;
  previous.at(1, 1) = 168;
  previous.at(4, 4) = detail::kInvalid;
  Plane<std::uint8_t> image(5, 5), before(5, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) image.at(x, y) = before.at(x, y) = 100;
  before.at(3, 3) = 113;  // changed by 13 > 12: moved
  const detail::TemporalPrior t{&previous, &image, &before, 1, 12};
  const detail::Interval band = detail::temporal_band_at(t, 0, 63, 2, 2);
  EXPECT_EQ(band.lo, 9);
  EXPECT_EQ(band.hi, 12);
  EXPECT_GT(detail::temporal_band_at(t, 0, 63, 3, 3).lo, detail::temporal_band_at(t, 0, 63, 3, 3).hi);  // moved
  EXPECT_GT(detail::temporal_band_at(t, 0, 63, 4, 4).lo, detail::temporal_band_at(t, 0, 63, 4, 4).hi);  // invalid
  EXPECT_EQ(detail::temporal_band_at(t, 0, 10, 2, 2).hi, 10);  // clipped to the range
  // Inside the coarser band [6, 14]: the union with its narrowed band [8, 11].
  detail::Interval r = detail::with_temporal_prior({6, 14}, {8, 11}, band);
  EXPECT_EQ(r.lo, 8);
  EXPECT_EQ(r.hi, 12);
  // Not inside [10, 14], or no band: the coarser band as it is.
  r = detail::with_temporal_prior({10, 14}, {11, 13}, band);
  EXPECT_EQ(r.lo, 10);
  EXPECT_EQ(r.hi, 14);
  r = detail::with_temporal_prior({6, 14}, {8, 11}, {1, 0});
  EXPECT_EQ(r.lo, 6);
  EXPECT_EQ(r.hi, 14);
}

TEST(Temporal, EverySimdTargetEqualsReference) {
  const std::vector<Scene> frames = {square_scene(60, 26, 1), square_scene(60, 26, 2), square_scene(63, 27, 3)};
  for (const auto& named : temporal_cases()) {
    // Named copies: a lambda may not capture structured bindings (C++20 as Clang 14 implements it).
    const std::string& name = named.first;
    const StereoParams& p = named.second;
    Matcher ref(kW, kH, p, Backend::Reference);
    for (const Scene& s : frames) ref.compute(s.left_view(), s.right_view());
    for_each_simd_target([&](const std::string& target) {
      Matcher m(kW, kH, p, Backend::Cpu);
      for (const Scene& s : frames) m.compute(s.left_view(), s.right_view());
      EXPECT_EQ(describe_difference(pixels(m.disparity_q4()), pixels(ref.disparity_q4()), kW), "")
          << name << " on " << target;
    });
  }
}

// The candidates of the finest level, per pixel and view.
double finest_candidates(const Matcher& m) { return m.level_work().front().candidates; }

// Matches `frames` with `preset`'s parameters, with the prior and alone, and checks every frame:
// the same frame alone is good (< 10 % bad), and the prior makes it worse by 0.5 points at most.
// Then calls check(f, candidates with the prior, candidates alone) at the finest level.
void compare_with_frames_alone(const std::vector<Scene>& frames, const char* name, const StereoParams& params,
                               const std::function<void(std::size_t, double, double)>& check) {
  SCOPED_TRACE(name);
  const StereoParams p = temporal(params);
  StereoParams alone_params = p;
  alone_params.temporal = false;
  Matcher seq(kW, kH, p), alone(kW, kH, alone_params);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    seq.compute(frames[f].left_view(), frames[f].right_view());
    alone.compute(frames[f].left_view(), frames[f].right_view());
    const double bad_seq = bad_fraction(frames[f], seq), bad_alone = bad_fraction(frames[f], alone);
    EXPECT_LT(bad_alone, 0.10) << "frame " << f;
    EXPECT_LE(bad_seq, bad_alone + 0.005) << "frame " << f;
    check(f, finest_candidates(seq), finest_candidates(alone));
  }
}

// The presets and SGM at every level, with the largest fraction of the candidates alone that the
// prior may leave at the finest level of a still scene.
struct TemporalCase {
  const char* name;
  StereoParams params;
  double fraction;
};

std::vector<TemporalCase> still_scene_cases() {
  return {{"balanced", preset("balanced"), 0.8}, {"quality", preset("quality"), 0.9},
          {"sgm every level", sgm_every_level(), 0.5}};
}

TEST(Temporal, StillSceneNeedsFewerCandidatesAndKeepsItsMap) {
  for (const TemporalCase& c : still_scene_cases()) {
    compare_with_frames_alone(still_frames(), c.name, c.params, [&c](std::size_t f, double with_prior, double alone) {
      if (f == 0) {
        EXPECT_EQ(with_prior, alone);
      } else {
        // Where the coarse map is flat, balanced and quality search 5 candidates around its prior
        // at their box-sum finest level (measured 6.3 and 6.7 per pixel with the edges), SGM at
        // the finest level 13 (radius 6), and with the previous frame's map all 3 (temporal
        // radius 1; measured 4.7, 5.6 and under a half).
        std::printf("%s frame %zu: %.2f candidates with the prior, %.2f alone\n", c.name, f, with_prior, alone);
        EXPECT_LT(with_prior, c.fraction * alone) << "frame " << f;
      }
    });
  }
}

TEST(Temporal, MotionAndCutAreNoWorseThanEachFrameAlone) {
  for (const TemporalCase& c : still_scene_cases()) {
    compare_with_frames_alone(moving_then_cut_frames(), c.name, c.params, [](std::size_t f, double with_prior, double alone) {
      // The prior never widens a search.
      EXPECT_LE(with_prior, alone) << "frame " << f;
    });
  }
}

// A level whose radius is the temporal radius or less searches as without the prior: realtime's
// radius is 1, the default temporal radius too.
TEST(Temporal, LevelsNoWiderThanTheTemporalRadiusAreUnchanged) {
  const StereoParams p = temporal(preset("realtime"));
  StereoParams alone_params = p;
  alone_params.temporal = false;
  Matcher seq(kW, kH, p), alone(kW, kH, alone_params);
  for (const Scene& s : moving_then_cut_frames()) {
    seq.compute(s.left_view(), s.right_view());
    alone.compute(s.left_view(), s.right_view());
    EXPECT_EQ(describe_difference(pixels(seq.disparity_q4()), pixels(alone.disparity_q4()), kW), "");
  }
  EXPECT_EQ(estimate_memory(p, kW, kH), estimate_memory(alone_params, kW, kH));
}

TEST(Temporal, ParametersAndMemory) {
  StereoParams p = temporal(preset("balanced"));
  for (int bad : {-1, 17}) {
    p.temporal_radius = bad;
    EXPECT_NE(p.validate().find("temporal_radius = " + std::to_string(bad) + " must be in [0, 16]"),
              std::string::npos);
  }
  p.temporal_radius = 1;
  EXPECT_EQ(p.validate(), "");
  for (int bad : {-1, 256}) {
    p.temporal_threshold = bad;
    EXPECT_NE(p.validate().find("temporal_threshold = " + std::to_string(bad) + " must be in [0, 255]"),
              std::string::npos);
  }
  p.temporal_threshold = 12;
  // The previous maps and images of the narrowed levels: balanced's two finer levels, both box
  // levels (both views at each); with SGM at the middle level, its left view only.
  StereoParams alone = p;
  alone.temporal = false;
  const std::size_t full = detail::Plane<std::int16_t>::bytes_for(kW, kH) + detail::Plane<std::uint8_t>::bytes_for(kW, kH);
  const std::size_t half =
      detail::Plane<std::int16_t>::bytes_for(kW / 2, kH / 2) + detail::Plane<std::uint8_t>::bytes_for(kW / 2, kH / 2);
  EXPECT_EQ(estimate_memory(p, kW, kH) - estimate_memory(alone, kW, kH), 2 * full + 2 * half);
  p.box_levels = alone.box_levels = 1;
  EXPECT_EQ(estimate_memory(p, kW, kH) - estimate_memory(alone, kW, kH), 2 * full + half);
}

}  // namespace
}  // namespace mctstereo::test
