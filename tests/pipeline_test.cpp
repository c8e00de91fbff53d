// The whole pipeline: cpu equals reference, across thread counts and SIMD targets; output
// conventions; no allocation per frame (opencl included).
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <thread>

#include "mctstereo/matcher.hpp"
#include "pipeline_cases.hpp"
#ifdef MCTSTEREO_HAVE_OPENCL
#include "opencl/opencl_test_util.hpp"
#endif

// Counts every operator new of the test process, so a test can assert that a frame allocates nothing.
// Clang's ThreadSanitizer runtime (the preset tsan) is linked statically and defines operator new
// and delete itself: there the count is not kept and the tests that need it skip.
#if defined(__SANITIZE_THREAD__)
#define MCTSTEREO_COUNTS_ALLOCATIONS 0
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define MCTSTEREO_COUNTS_ALLOCATIONS 0
#endif
#endif
#ifndef MCTSTEREO_COUNTS_ALLOCATIONS
#define MCTSTEREO_COUNTS_ALLOCATIONS 1
#endif
namespace {
std::atomic<long> g_allocations{0};
constexpr bool kCountsAllocations = MCTSTEREO_COUNTS_ALLOCATIONS;
}  // namespace
#if MCTSTEREO_COUNTS_ALLOCATIONS
void* operator new(std::size_t n) {
  ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#endif

namespace mctstereo::test {
namespace {

std::vector<std::int16_t> run(const StereoPair& pair, const StereoParams& params, Backend backend, int threads,
                              bool right = false) {
  MatcherOptions options;
  options.threads = threads;
  options.compute_right = right;
  Matcher m(pair.left.width(), pair.left.height(), params, backend, options);
  m.compute(pair.left_view(), pair.right_view());
  return pixels(right ? m.right_disparity_q4() : m.disparity_q4());
}

TEST(Pipeline, CpuEqualsReferenceForEveryPresetAndAwkwardCase) {
  for (const PipelineCase& c : pipeline_cases()) {
    SCOPED_TRACE(c.name);
    const StereoPair pair = textured_pair(c.w, c.h, c.max_disparity(), 11);
    const auto ref = run(pair, c.params, Backend::Reference, 1);
    for (int threads : {1, 2}) {
      EXPECT_EQ(describe_difference(run(pair, c.params, Backend::Cpu, threads), ref, c.w), "") << "threads " << threads;
    }
    if (c.params.lr_check) {
      EXPECT_EQ(describe_difference(run(pair, c.params, Backend::Cpu, 2, true),
                                    run(pair, c.params, Backend::Reference, 1, true), c.w),
                "")
          << "right view";
    }
  }
}

TEST(Pipeline, LargeOddFrameEqualAcrossThreadsAndSimdTargets) {
  StereoParams p = preset("balanced");
  p.num_disparities = 48;
  const StereoPair pair = textured_pair(631, 479, 40, 5);
  const auto ref = run(pair, p, Backend::Reference, 1);
  for_each_simd_target([&](const std::string& target) {
    for (int threads : {1, 2, 3}) {
      EXPECT_EQ(describe_difference(run(pair, p, Backend::Cpu, threads), ref, 631), "")
          << target << ", threads " << threads;
    }
  });
}

TEST(Pipeline, EveryPresetEqualAcrossSimdTargets) {
  const StereoPair pair = textured_pair(130, 70, 20, 3);
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    p.num_disparities = 24;
    const auto ref = run(pair, p, Backend::Reference, 1);
    for_each_simd_target([&](const std::string& target) {
      EXPECT_EQ(describe_difference(run(pair, p, Backend::Cpu, 2), ref, 130), "") << name << " on " << target;
    });
  }
}

// Matchers are independent: several at once, each on its own thread of the caller with two OpenMP
// threads of its own, give the reference's maps frame after frame (under ThreadSanitizer, the
// tsan preset, this is also the check that they share nothing unguarded).
TEST(Pipeline, SeveralMatchersAtOnceOnThreadsOfTheCallerEqualTheReference) {
  const std::vector<std::string> names = {"realtime", "balanced", "mr-mct-5x5"};
  const StereoPair pair = textured_pair(97, 41, 14, 21);
  std::vector<StereoParams> params;
  std::vector<std::vector<std::int16_t>> expected;
  for (const std::string& name : names) {
    StereoParams p = preset(name);
    p.num_disparities = 16;
    params.push_back(p);
    expected.push_back(run(pair, p, Backend::Reference, 1));
  }
  std::vector<std::vector<std::string>> differences(names.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < names.size(); ++i)
    threads.emplace_back([&, i] {
      MatcherOptions options;
      options.threads = 2;
      Matcher m(pair.left.width(), pair.left.height(), params[i], Backend::Cpu, options);
      for (int frame = 0; frame < 3; ++frame) {
        m.compute(pair.left_view(), pair.right_view());
        differences[i].push_back(describe_difference(pixels(m.disparity_q4()), expected[i], 97));
      }
    });
  for (std::thread& t : threads) t.join();
  for (std::size_t i = 0; i < names.size(); ++i) {
    ASSERT_EQ(differences[i].size(), 3u) << names[i];
    for (const std::string& d : differences[i]) EXPECT_EQ(d, "") << names[i];
  }
}

TEST(Pipeline, OutputConventions) {
  StereoParams p = preset("balanced");
  p.min_disparity = -3;
  p.num_disparities = 20;
  p.fill = FillMode::None;
  p.uniqueness_ratio = 30;  // leaves invalid pixels
  p.weighted_median = false;  // which would give them the value of their neighbours
  const StereoPair pair = textured_pair(120, 40, 10, 9);
  Matcher m(120, 40, p);
  m.compute(pair.left_view(), pair.right_view());
  EXPECT_EQ(m.invalid_q4(), -4 * 16);
  const auto q4 = m.disparity_q4();
  const auto f = m.disparity();
  int invalid = 0;
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 120; ++x) {
      const int v = q4.at(x, y);
      if (v == m.invalid_q4()) {
        ++invalid;
        EXPECT_TRUE(std::isnan(f.at(x, y)));
      } else {
        EXPECT_GE(v, 16 * p.min_disparity);
        EXPECT_LE(v, 16 * p.max_disparity());
        EXPECT_EQ(f.at(x, y), v / 16.0f);
      }
    }
  EXPECT_GT(invalid, 0);
  EXPECT_EQ(m.timings().back().stage, "frame");
  EXPECT_GT(m.timings().back().ms, 0.0);
}

TEST(Pipeline, FloatMapFollowsEveryFrame) {
  // The float map is made on demand: after each compute() it must show that frame, whether or not
  // it was read after the frame before, and reading it allocates nothing.
  StereoParams p = preset("realtime");
  p.num_disparities = 24;
  const StereoPair near = textured_pair(96, 48, 4, 3), far = textured_pair(96, 48, 14, 4);
  Matcher m(96, 48, p);
  const auto expect_float_matches_q4 = [&](const char* what) {
    const auto q4 = m.disparity_q4();
    const long before = g_allocations.load();
    const auto f = m.disparity();
    if (kCountsAllocations) EXPECT_EQ(g_allocations.load() - before, 0) << what;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 96; ++x) {
        const int v = q4.at(x, y);
        if (v == m.invalid_q4()) ASSERT_TRUE(std::isnan(f.at(x, y))) << what;
        else ASSERT_EQ(f.at(x, y), v / 16.0f) << what << " at " << x << "," << y;
      }
  };
  m.compute(near.left_view(), near.right_view());
  expect_float_matches_q4("first frame");
  m.compute(far.left_view(), far.right_view());
  m.compute(near.left_view(), near.right_view());  // the middle frame's float map is never read
  expect_float_matches_q4("third frame");
  m.compute(far.left_view(), far.right_view());
  expect_float_matches_q4("fourth frame");
  EXPECT_NE(m.disparity_q4().at(60, 24), 16 * 4);  // the frames differ where it is checked
}

TEST(Pipeline, ColourInputEqualsItsLuma) {
  const int w = 64, h = 32;
  std::vector<std::uint8_t> rgb(w * h * 3), gray_l(w * h), gray_r(w * h), bgr(w * h * 3);
  const StereoPair pair = textured_pair(w, h, 8, 21);
  // Colour pixels whose luma is the pair's gray value: R = G = B = value.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const int i = y * w + x;
      gray_l[i] = pair.left.at(x, y);
      gray_r[i] = pair.right.at(x, y);
      for (int c = 0; c < 3; ++c) rgb[3 * i + c] = pair.left.at(x, y);
    }
  StereoParams p = preset("realtime");
  p.num_disparities = 16;
  Matcher colour(w, h, p), gray(w, h, p);
  colour.compute({rgb.data(), w, h, 3 * w, PixelFormat::Rgb8}, {gray_r.data(), w, h, w, PixelFormat::Gray8});
  gray.compute({gray_l.data(), w, h, w, PixelFormat::Gray8}, {gray_r.data(), w, h, w, PixelFormat::Gray8});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) ASSERT_EQ(colour.disparity_q4().at(x, y), gray.disparity_q4().at(x, y));
}

// The colour-weighted median on colour input: cpu == reference (RGB and BGR, padded rows, working
// scales 1 and 2), RGB and BGR of the same pixels give the same map, and the map differs from the
// one the stage makes from gray input (it does use the colour).
TEST(Pipeline, WeightedMedianOnColourInput) {
  const int w = 89, h = 41;
  const ColourPair rgb(w, h, 14, 31, PixelFormat::Rgb8, 5), bgr(w, h, 14, 31, PixelFormat::Bgr8, 0);
  const StereoPair& gray = rgb.luma;
  ASSERT_EQ(first_difference(gray.left, bgr.luma.left), "");
  for (int scale : {1, 2}) {
    StereoParams p = preset("balanced");
    p.weighted_median = true;
    p.num_disparities = 24;
    p.working_scale = scale;
    const auto run_view = [&](const ImageView& left, const StereoParams& params, Backend b, int threads) {
      MatcherOptions options;
      options.threads = threads;
      Matcher m(w, h, params, b, options);
      m.compute(left, gray.right_view());
      return pixels(m.disparity_q4());
    };
    const auto ref = run_view(rgb.left.view, p, Backend::Reference, 1);
    for (int threads : {1, 2})
      EXPECT_EQ(describe_difference(run_view(rgb.left.view, p, Backend::Cpu, threads), ref, w), "")
          << "scale " << scale << " threads " << threads;
    EXPECT_EQ(describe_difference(run_view(bgr.left.view, p, Backend::Reference, 1), ref, w), "") << "bgr " << scale;
    EXPECT_EQ(describe_difference(run_view(bgr.left.view, p, Backend::Cpu, 2), ref, w), "") << "bgr " << scale;
    // The same luma as gray input: only the weighted median's weights differ.
    EXPECT_NE(run_view(gray.left_view(), p, Backend::Cpu, 2), ref) << "scale " << scale;
    StereoParams off = p;
    off.weighted_median = false;
    const auto plain = run_view(rgb.left.view, off, Backend::Cpu, 2);
    EXPECT_EQ(plain, run_view(gray.left_view(), off, Backend::Cpu, 2)) << "without the stage colour is its luma";
    EXPECT_NE(plain, ref) << "the stage changes the map";
  }
}

TEST(Pipeline, RejectsWrongInput) { expect_rejects_wrong_input(Backend::Cpu); }

TEST(Pipeline, ComputeAllocatesNothingPerFrame) {
  if (!kCountsAllocations) GTEST_SKIP() << "allocations are not counted under ThreadSanitizer";
  const StereoPair pair = textured_pair(160, 120, 20, 1);
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    p.num_disparities = 32;
    for (Backend b : {Backend::Reference, Backend::Cpu}) {
      Matcher m(160, 120, p, b);
      m.compute(pair.left_view(), pair.right_view());  // warm-up: thread pool, dispatch tables
      const long before = g_allocations.load();
      m.compute(pair.left_view(), pair.right_view());
      m.compute(pair.left_view(), pair.right_view());
      EXPECT_EQ(g_allocations.load() - before, 0) << name << " " << to_string(b);
    }
  }
  // The colour-weighted median, on colour and gray input, at working scales 1 and 2.
  const ColourView rgb(pair.left, PixelFormat::Rgb8, 3, 5);  // the stage's colour; matching sees its luma
  for (int scale : {1, 2}) {
    StereoParams p = preset("quality");
    p.weighted_median = true;
    p.num_disparities = 32;
    p.working_scale = scale;
    for (Backend b : {Backend::Reference, Backend::Cpu}) {
      Matcher m(160, 120, p, b);
      m.compute(rgb.view, pair.right_view());
      const long before = g_allocations.load();
      m.compute(rgb.view, pair.right_view());
      m.compute(pair.left_view(), pair.right_view());
      m.compute(rgb.view, pair.right_view());
      EXPECT_EQ(g_allocations.load() - before, 0) << "weighted median, scale " << scale << " " << to_string(b);
    }
  }
}

#ifdef MCTSTEREO_HAVE_OPENCL
// The opencl backend: its constructor makes every kernel and runs a blank frame, so a frame only
// sets kernel arguments, enqueues, waits and downloads. The count covers the whole process, the
// OpenCL implementation and its threads included: on PoCL that is honest too, since its runtime
// is C (malloc), and its LLVM parts, which do use operator new, run only while programs are built
// and work-group functions compiled, which the constructor and the first frame have done. A driver
// that allocated per enqueue would fail this test and need a count of the library's own calls.
TEST(Pipeline, OpenclComputeAllocatesNothingPerFrame) {
  if (!kCountsAllocations) GTEST_SKIP() << "allocations are not counted under ThreadSanitizer";
  MCTSTEREO_OPENCL_TEST_RUNTIME(rt);
  const StereoPair pair = textured_pair(160, 120, 20, 1);
  std::vector<std::uint8_t> rgb(160 * 120 * 3);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x)
      for (int c = 0; c < 3; ++c) rgb[(y * 160 + x) * 3 + c] = pair.left.at(x, y);
  const ImageView rgb_left{rgb.data(), 160, 120, 160 * 3, PixelFormat::Rgb8};
  MatcherOptions options;
  options.device = std::to_string(rt->device().index);
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    p.num_disparities = 32;
    // The right map and colour input (the conversion kernel) with one preset, speckle removal
    // (on the host) and a working scale of 2 (upscaling) with others.
    options.compute_right = name == "balanced";
    if (name == "realtime") p.working_scale = 2;
    const ImageView left = name == "balanced" ? rgb_left : pair.left_view();
    Matcher m(160, 120, p, Backend::OpenCL, options);
    m.compute(left, pair.right_view());
    const long before = g_allocations.load();
    m.compute(left, pair.right_view());
    m.compute(left, pair.right_view());
    (void)m.disparity();  // the float map's download
    EXPECT_EQ(g_allocations.load() - before, 0) << name;
  }  // The colour-weighted median on colour and gray input.
  StereoParams p = preset("balanced");
  p.weighted_median = true;
  p.num_disparities = 32;
  options.compute_right = false;
  Matcher m(160, 120, p, Backend::OpenCL, options);
  m.compute(rgb_left, pair.right_view());
  m.compute(pair.left_view(), pair.right_view());
  const long before = g_allocations.load();
  m.compute(rgb_left, pair.right_view());
  m.compute(pair.left_view(), pair.right_view());
  (void)m.disparity();
  EXPECT_EQ(g_allocations.load() - before, 0) << "weighted median";
}
#endif

// The confidence map: empty before a frame and for box aggregation unless asked for; in [0, 1], 0
// where the checks invalidated a pixel, and mostly high on a clean textured pair.
TEST(Pipeline, ConfidenceMapOfSgm) {
  const StereoPair pair = textured_pair(120, 60, 12, 4);
  StereoParams p = preset("balanced");
  p.num_disparities = 24;
  // balanced (box sums at the finest level, whose margins the confidence takes), then SGM at
  // every level (the margins of the sums).
  for (const int box_levels : {1, 0}) {
    SCOPED_TRACE(box_levels);
    p.box_levels = box_levels;
    Matcher m(120, 60, p);
    EXPECT_EQ(m.confidence().data, nullptr);
    m.compute(pair.left_view(), pair.right_view());
    const auto c = m.confidence();
    ASSERT_NE(c.data, nullptr);
    int high = 0;
    for (int y = 0; y < 60; ++y)
      for (int x = 0; x < 120; ++x) {
        EXPECT_GE(c.at(x, y), 0.0f);
        EXPECT_LE(c.at(x, y), 1.0f);
        high += c.at(x, y) > 0.2f;
      }
    EXPECT_GT(high, 120 * 60 / 2);
    // The pixels left of the smallest visible disparity have no match: the checks drop them.
    EXPECT_EQ(c.at(0, 30), 0.0f);
  }
  StereoParams box = p;
  box.aggregation = Aggregation::Box;
  box.prior_size = 3;
  box.box_levels = 0;
  Matcher local(120, 60, box);
  local.compute(pair.left_view(), pair.right_view());
  EXPECT_EQ(local.confidence().data, nullptr);
}

// The host backends compute the confidence when confidence() is first called after a frame, from
// the left map kept before the fill (with compute_right, within the frame): read late (after the
// disparity maps, or only after the next frame), it is still the last frame's, bit for bit what a
// matcher that saw only that frame gives; read twice, the same. With and without the right map,
// SGM and box aggregation, 1 and 2 threads.
TEST(Pipeline, ConfidenceReadLateIsTheLastFrames) {
  const StereoPair first = textured_pair(97, 45, 10, 7), second = textured_pair(97, 45, 10, 8);
  for (const std::string& name : {std::string("balanced"), std::string("quality"), std::string("realtime")}) {
    StereoParams p = preset(name);
    p.num_disparities = 16;
    for (const bool right : {false, true})
      for (const int threads : {1, 2}) {
        SCOPED_TRACE(name + (right ? ", compute_right, " : ", ") + std::to_string(threads) + " threads");
        MatcherOptions options;
        options.compute_right = right;
        options.compute_confidence = true;
        options.threads = threads;
        Matcher alone(97, 45, p, Backend::Cpu, options), late(97, 45, p, Backend::Cpu, options),
            each(97, 45, p, Backend::Cpu, options);
        alone.compute(second.left_view(), second.right_view());
        late.compute(first.left_view(), first.right_view());
        (void)late.disparity();
        late.compute(second.left_view(), second.right_view());
        (void)late.disparity();
        each.compute(first.left_view(), first.right_view());
        const std::vector<std::uint32_t> of_first = confidence_bits(each);
        each.compute(second.left_view(), second.right_view());
        EXPECT_EQ(confidence_difference(alone, late), "");
        EXPECT_EQ(confidence_difference(alone, each), "");
        EXPECT_EQ(confidence_difference(alone, each), "") << "read twice";
        EXPECT_NE(of_first, confidence_bits(each)) << "the frames' confidences should differ";
      }
  }
}

// Box aggregation with compute_confidence: the margin of the box costs times the agreement, equal
// on the reference and cpu backends (1 and 2 threads) for every box preset; mostly high on a clean
// pair and 0 where no candidate lies in the image. Asking for it leaves the disparity map as it is.
TEST(Pipeline, ConfidenceMapOfBoxAggregation) {
  const StereoPair pair = textured_pair(123, 61, 12, 4);
  int box_presets = 0;
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    if (p.sgm()) continue;
    ++box_presets;
    SCOPED_TRACE(name);
    p.num_disparities = 24;
    MatcherOptions options;
    options.compute_confidence = true;
    Matcher ref(123, 61, p, Backend::Reference, options);
    EXPECT_EQ(ref.confidence().data, nullptr) << "no confidence before the first frame";
    ref.compute(pair.left_view(), pair.right_view());
    const auto c = ref.confidence();
    ASSERT_NE(c.data, nullptr);
    int high = 0;
    for (int y = 0; y < 61; ++y)
      for (int x = 0; x < 123; ++x) {
        EXPECT_GE(c.at(x, y), 0.0f);
        EXPECT_LE(c.at(x, y), 1.0f);
        high += c.at(x, y) > 0.2f;
      }
    EXPECT_GT(high, 123 * 61 / 3);
    EXPECT_EQ(c.at(0, 30), 0.0f);
    for (int threads : {1, 2}) {
      options.threads = threads;
      Matcher cpu(123, 61, p, Backend::Cpu, options);
      cpu.compute(pair.left_view(), pair.right_view());
      EXPECT_EQ(confidence_difference(cpu, ref), "") << threads << " threads";
      EXPECT_EQ(describe_difference(pixels(cpu.disparity_q4()), run(pair, p, Backend::Cpu, threads), 123), "");
    }
  }
  EXPECT_GE(box_presets, 4);
}

// level_work(): the coarsest level searches its whole range; on a pair shifted by one constant
// disparity every finer level searches about 2 r + 1 candidates around the prior; band SGM counts
// its volume's candidates, of one view. Equal on the reference and cpu backends.
TEST(Pipeline, LevelWorkCountsTheCandidatesOfEachLevel) {
  ShiftedPair shifted = shifted_pair(256, 128, 5, 16);
  const StereoPair pair{std::move(shifted.left), std::move(shifted.right)};
  StereoParams p = preset("realtime");  // 4 levels, radius 1, LR check: both views
  p.num_disparities = 64;
  Matcher m(256, 128, p);
  EXPECT_TRUE(m.level_work().empty()) << "no frame yet";
  const ImageView left = pair.left_view(), right = pair.right_view();
  m.compute(left, right);
  const std::vector<LevelWork> work = m.level_work();
  ASSERT_EQ(work.size(), 4u);
  EXPECT_EQ(work[0].width, 256);
  EXPECT_EQ(work[3].width, 32);
  EXPECT_EQ(work[3].height, 16);
  for (const LevelWork& w : work) EXPECT_EQ(w.views, 2);
  EXPECT_DOUBLE_EQ(work[3].candidates, 9.0) << "0 .. ceil(63 / 8)";
  // realtime checks the left map on the right map's grid: the finest level matches the right
  // view at its even rows only, three quarters of the pairs of both views in full.
  StereoParams full_right = p;
  full_right.lr_check_grid = false;
  Matcher full(256, 128, full_right);
  full.compute(left, right);
  const std::vector<LevelWork> full_work = full.level_work();
  for (int l = 0; l < 3; ++l) {
    EXPECT_GE(full_work[l].candidates, 2.5) << "level " << l;
    EXPECT_LE(full_work[l].candidates, 3.6) << "level " << l;
    if (l > 0) EXPECT_DOUBLE_EQ(work[l].candidates, full_work[l].candidates) << "level " << l;
  }
  EXPECT_NEAR(work[0].candidates / full_work[0].candidates, 0.75, 0.03);
  EXPECT_DOUBLE_EQ(work[0].pairs(), 256.0 * 128 * 2 * work[0].candidates);
  Matcher ref(256, 128, p, Backend::Reference);
  ref.compute(left, right);
  for (int l = 0; l < 4; ++l) EXPECT_DOUBLE_EQ(ref.level_work()[l].candidates, work[l].candidates);

  StereoParams sgm = preset("balanced");
  sgm.num_disparities = 64;
  sgm.box_levels = 0;  // SGM at every level
  Matcher band(256, 128, sgm);
  band.compute(left, right);
  const std::vector<LevelWork> band_work = band.level_work();
  ASSERT_EQ(band_work.size(), static_cast<std::size_t>(sgm.pyramid_levels));
  for (const LevelWork& w : band_work) EXPECT_EQ(w.views, 1);
  // The coarsest level (64 wide) holds 0 .. floor(63 / 4) = 15 (a coarsest band SGM level ends at
  // the floor) where x - d stays in the image: min(16, x + 1) candidates at column x,
  // (1 + ... + 16 + 48 x 16) / 64 per pixel.
  EXPECT_EQ(band_work.back().width, 64);
  EXPECT_DOUBLE_EQ(band_work.back().candidates, (136.0 + 48 * 16) / 64);
  EXPECT_GE(band_work.front().candidates, 5.0);
  EXPECT_LE(band_work.front().candidates, static_cast<double>(sgm.sgm_max_band));

  // balanced: the finest level matches both views with box sums around the SGM level's maps
  // (3x3 prior, radius 2: at least 5 candidates), the SGM levels count as before.
  sgm.box_levels = 1;
  Matcher hybrid(256, 128, sgm);
  hybrid.compute(left, right);
  const std::vector<LevelWork> hybrid_work = hybrid.level_work();
  ASSERT_EQ(hybrid_work.size(), band_work.size());
  EXPECT_EQ(hybrid_work[0].views, 2);
  EXPECT_GE(hybrid_work[0].candidates, 5.0);
  EXPECT_LE(hybrid_work[0].candidates, 20.0);
  for (std::size_t l = 1; l < hybrid_work.size(); ++l) {
    EXPECT_EQ(hybrid_work[l].views, 1) << l;
    EXPECT_DOUBLE_EQ(hybrid_work[l].candidates, band_work[l].candidates) << l;
  }
}

// Band SGM in segments of rows (MatcherOptions::sgm_volume_limit 0: every 4-path SGM level in
// segments) makes the maps of the whole volume: both views, the confidence, several frames.
TEST(Pipeline, SgmInSegmentsEqualsTheWholeVolume) {
  const StereoPair pair = textured_pair(203, 97, 30, 8);
  const StereoPair next = textured_pair(203, 97, 30, 9);
  for (const std::string& name : {"balanced", "quality", "sgm-full"}) {
    StereoParams p = preset(name);
    p.num_disparities = 32;
    // balanced's one SGM level (the coarsest, 51 x 25) is a single segment: with SGM at the
    // middle level too, that level (101 x 48, a band around the coarsest map's) is segmented.
    if (name == "balanced") p.box_levels = 1;
    MatcherOptions whole, segments;
    whole.compute_right = segments.compute_right = true;
    whole.threads = segments.threads = 2;
    whole.sgm_volume_limit = SIZE_MAX;
    segments.sgm_volume_limit = 0;
    Matcher a(203, 97, p, Backend::Cpu, whole), b(203, 97, p, Backend::Cpu, segments);
    for (const StereoPair* frame : {&pair, &next}) {
      a.compute(frame->left_view(), frame->right_view());
      b.compute(frame->left_view(), frame->right_view());
      EXPECT_EQ(describe_difference(pixels(b.disparity_q4()), pixels(a.disparity_q4()), 203), "") << name;
      EXPECT_EQ(describe_difference(pixels(b.right_disparity_q4()), pixels(a.right_disparity_q4()), 203), "") << name;
      const MapView<const float> ca = a.confidence();
      const MapView<const float> cb = b.confidence();
      long differ = 0;
      for (int y = 0; y < 97; ++y)
        for (int x = 0; x < 203; ++x) differ += ca.at(x, y) != cb.at(x, y);
      EXPECT_EQ(differ, 0) << name;
    }
    // The segmented matcher holds less: one segment's costs and sums instead of the level's.
    EXPECT_LT(estimate_memory(p, 203, 97, segments), estimate_memory(p, 203, 97, whole)) << name;
  }
}

// MatcherOptions::adapt_threads runs some frames of a matcher of 2 threads on the calling thread
// alone (at least the first trial's, frames 4 to 6): every preset, the maps, right maps and
// confidence of all the threads frame after frame.
TEST(Pipeline, AdaptingTheThreadsKeepsTheMaps) {
  const StereoPair pair = textured_pair(203, 97, 30, 8);
  for (const std::string& name : preset_names()) {
    StereoParams p = preset(name);
    p.num_disparities = 32;
    MatcherOptions adapting, fixed;
    adapting.threads = fixed.threads = 2;
    adapting.compute_right = fixed.compute_right = true;
    adapting.compute_confidence = fixed.compute_confidence = true;
    fixed.adapt_threads = false;
    Matcher a(203, 97, p, Backend::Cpu, adapting), b(203, 97, p, Backend::Cpu, fixed);
    if (a.threads() < 2) GTEST_SKIP() << "one hardware thread";
    for (int frame = 0; frame < 20; ++frame) {
      a.compute(pair.left_view(), pair.right_view());
      b.compute(pair.left_view(), pair.right_view());
      ASSERT_EQ(describe_difference(pixels(a.disparity_q4()), pixels(b.disparity_q4()), 203), "") << name << frame;
      ASSERT_EQ(describe_difference(pixels(a.right_disparity_q4()), pixels(b.right_disparity_q4()), 203), "")
          << name << frame;
      const MapView<const float> ca = a.confidence(), cb = b.confidence();
      long differ = 0;
      for (int y = 0; y < 97; ++y)
        for (int x = 0; x < 203; ++x) differ += ca.at(x, y) != cb.at(x, y);
      ASSERT_EQ(differ, 0) << name << frame;
    }
    EXPECT_GE(a.frames_alone(), 2) << name;
    EXPECT_EQ(b.frames_alone(), 0) << name;
  }
}

// set_single_threaded(true) runs exactly the frames between it and set_single_threaded(false) on
// the caller's thread alone (frames_alone counts them), with the maps of all the threads.
TEST(Pipeline, SingleThreadedFramesKeepTheMaps) {
  const StereoPair pair = textured_pair(203, 97, 30, 8);
  StereoParams p = preset("balanced");
  p.num_disparities = 32;
  MatcherOptions options;
  options.threads = 2;
  options.adapt_threads = false;
  Matcher a(203, 97, p, Backend::Cpu, options), b(203, 97, p, Backend::Cpu, options);
  if (a.threads() < 2) GTEST_SKIP() << "one hardware thread";
  EXPECT_FALSE(a.single_threaded());
  for (int frame = 0; frame < 8; ++frame) {
    a.set_single_threaded(frame >= 3 && frame < 6);
    EXPECT_EQ(a.single_threaded(), frame >= 3 && frame < 6);
    a.compute(pair.left_view(), pair.right_view());
    b.compute(pair.left_view(), pair.right_view());
    ASSERT_EQ(describe_difference(pixels(a.disparity_q4()), pixels(b.disparity_q4()), 203), "") << frame;
    EXPECT_EQ(a.frames_alone(), std::clamp(frame - 2, 0, 3)) << frame;
  }
  EXPECT_EQ(b.frames_alone(), 0);
}

// Band SGM's memory at 1280 x 720 against balanced's (box sums at its two finer levels, band SGM
// over the whole range at the coarsest). quality holds its middle level's band of up to 32
// candidates whole (55.3 MiB with 256 disparities, 54.4 with 64, against balanced's 40.8 and 32.0,
// whose coarsest volume with 64 is a quarter of that of 256): under 1.5 x with 256, 1.8 x with 64.
// SGM at every level, the most it holds, segments its finest level by default: under 1.5 x and
// 1.6 x, and under half of its whole volume.
TEST(Pipeline, SgmMemoryAt720p) {
  const double mib = 1024.0 * 1024.0;
  MatcherOptions whole;
  whole.sgm_volume_limit = SIZE_MAX;
  for (int d : {64, 256}) {
    StereoParams q = preset("quality"), all = sgm_every_level(), b = preset("balanced");
    q.num_disparities = all.num_disparities = b.num_disparities = d;
    const double quality = estimate_memory(q, 1280, 720) / mib, balanced = estimate_memory(b, 1280, 720) / mib;
    const double segmented = estimate_memory(all, 1280, 720) / mib, full = estimate_memory(all, 1280, 720, whole) / mib;
    std::printf("%d disparities: quality %.1f MiB, SGM at every level %.1f (whole volume %.1f), balanced %.1f\n", d,
                quality, segmented, full, balanced);
    EXPECT_LT(quality, (d == 256 ? 1.5 : 1.8) * balanced);
    EXPECT_LT(segmented, (d == 256 ? 1.5 : 1.6) * balanced);
    EXPECT_LT(segmented, 0.5 * full);
  }
}

// Only the coarsest level searches the whole range, at a sixteenth of the pixels (3 levels); the
// finer levels hold bands of a fixed width.
TEST(Pipeline, MemoryGrowsWithTheSearchWidthNotTheRange) {
  for (const std::string& name : {"realtime", "balanced", "quality"}) {
    StereoParams p = preset(name);
    p.num_disparities = 64;
    const std::size_t m64 = estimate_memory(p, 1280, 720);
    p.num_disparities = 256;
    const std::size_t m256 = estimate_memory(p, 1280, 720);
    std::printf("%s: %.1f MiB at 64 disparities, %.1f at 256\n", name.c_str(), m64 / 1048576.0, m256 / 1048576.0);
    // A full cost volume would grow by 4x; the matcher's buffers grow by less than a third
    // (balanced: 34.7 to 43.5 MiB, the coarsest level's SGM costs and sums of 16 to 64 candidates).
    EXPECT_LT(static_cast<double>(m256), 1.3 * static_cast<double>(m64)) << name;
    // What they add is under a sixteenth of what a 16-bit cost volume of the whole image adds.
    EXPECT_LT(static_cast<double>(m256) - static_cast<double>(m64), 1280.0 * 720 * (256 - 64) * 2 / 16) << name;
    // Under a quarter of one 16-bit cost volume (quality holds costs and sums of up to 32
    // candidates per pixel at the finest level, in segments of rows).
    EXPECT_LT(m256, std::size_t{1280} * 720 * 256 * 2 / 4) << name;
  }
}

}  // namespace
}  // namespace mctstereo::test
