// Quality on Middlebury v2 scenes against ground truth: the bundled Tsukuba always, the four
// scenes of ../shared/data/middlebury2003 when that folder exists. Each bound sits just above what
// the code measures (docs/RESULTS.md), so that a regression fails.
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <map>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "test_util.hpp"

namespace mctstereo::test {
namespace {

namespace fs = std::filesystem;

struct Scores {
  double nonocc = 0, all = 0, disc = 0;
};

std::map<std::string, std::string> read_scene_txt(const fs::path& file) {
  std::map<std::string, std::string> kv;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto eq = line.find('=');
    if (eq != std::string::npos) kv[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return kv;
}

// A scene matched with a preset over its own range: ground truth, masks and the matcher's frame.
struct MatchedScene {
  cv::Mat gt, masks[3];  // nonocc, all, disc
  double scale = 1;
  Matcher matcher;
  int width() const { return gt.cols; }
  int height() const { return gt.rows; }
  // Whether (x, y) has ground truth in mask k, and whether the map is wrong there (> 1 px, or none).
  bool counted(int k, int x, int y) const { return masks[k].at<std::uint8_t>(y, x) == 255 && gt.at<std::uint8_t>(y, x) != 0; }
  bool bad(int x, int y) const {
    const float d = matcher.disparity().at(x, y);
    return std::isnan(d) || std::fabs(d - gt.at<std::uint8_t>(y, x) / scale) > 1.0;
  }
};

MatchedScene match_scene(const fs::path& dir, const std::string& preset_name) {
  auto kv = read_scene_txt(dir / "scene.txt");
  // The views go in as colour, converted by the library, exactly as `mctstereo eval` does;
  // IMREAD_GRAYSCALE expands the palette PNGs (ground truth, masks) to their gray values.
  const cv::Mat left = cv::imread((dir / kv["left"]).string(), cv::IMREAD_COLOR);
  const cv::Mat right = cv::imread((dir / kv["right"]).string(), cv::IMREAD_COLOR);
  const cv::Mat gt = cv::imread((dir / kv["gt"]).string(), cv::IMREAD_GRAYSCALE);
  const cv::Mat masks[3] = {cv::imread((dir / "nonocc.png").string(), cv::IMREAD_GRAYSCALE),
                            cv::imread((dir / "all.png").string(), cv::IMREAD_GRAYSCALE),
                            cv::imread((dir / "disc.png").string(), cv::IMREAD_GRAYSCALE)};
  EXPECT_FALSE(left.empty() || right.empty() || gt.empty() || masks[0].empty() || masks[1].empty() ||
               masks[2].empty())
      << dir;
  StereoParams p = preset(preset_name);
  p.min_disparity = 0;
  p.num_disparities = std::stoi(kv["max_disp"]) + 1;
  // Box presets make their confidence map too (the Middlebury figures do not depend on it).
  MatcherOptions options;
  options.compute_confidence = true;
  MatchedScene scene{gt,
                     {masks[0], masks[1], masks[2]},
                     std::stod(kv["gt_scale"]),
                     Matcher(left.cols, left.rows, p, Backend::Cpu, options)};
  scene.matcher.compute(
      {left.data, left.cols, left.rows, static_cast<std::ptrdiff_t>(left.step), PixelFormat::Bgr8},
      {right.data, right.cols, right.rows, static_cast<std::ptrdiff_t>(right.step), PixelFormat::Bgr8});
  return scene;
}

// Bad pixels (|d - gt| > 1, invalid counted as bad) in the nonocc, all and disc (== 255) masks.
Scores score_scene(const fs::path& dir, const std::string& preset_name) {
  const MatchedScene m = match_scene(dir, preset_name);
  double out[3];
  for (int k = 0; k < 3; ++k) {
    long n = 0, bad = 0;
    for (int y = 0; y < m.height(); ++y)
      for (int x = 0; x < m.width(); ++x) {
        if (!m.counted(k, x, y)) continue;
        ++n;
        bad += m.bad(x, y);
      }
    out[k] = 100.0 * bad / std::max(n, 1L);
  }
  return {out[0], out[1], out[2]};
}

// Bad pixels (> 1 px, invalid = bad) in the 'all' mask of every pixel with ground truth, and of the
// half of them that the matcher's confidence ranks highest (ties in row order).
struct Sparsification {
  double all = 0, confident_half = 0;
};
Sparsification sparsification(const fs::path& dir, const std::string& preset_name) {
  const MatchedScene m = match_scene(dir, preset_name);
  const MapView<const float> confidence = m.matcher.confidence();
  EXPECT_NE(confidence.data, nullptr) << preset_name;
  if (confidence.data == nullptr) return {};
  std::vector<std::pair<float, bool>> pixels;  // (confidence, bad)
  for (int y = 0; y < m.height(); ++y)
    for (int x = 0; x < m.width(); ++x)
      if (m.counted(1, x, y)) pixels.push_back({confidence.at(x, y), m.bad(x, y)});
  std::stable_sort(pixels.begin(), pixels.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  const auto percent_bad = [&](std::size_t n) {
    std::size_t bad = 0;
    for (std::size_t i = 0; i < n; ++i) bad += pixels[i].second;
    return 100.0 * bad / std::max<std::size_t>(n, 1);
  };
  return {percent_bad(pixels.size()), percent_bad((pixels.size() + 1) / 2)};
}

// Upper bounds (percent bad) per preset and scene: nonocc, all, disc.
struct Bound {
  const char* preset;
  const char* scene;
  Scores max;
};
#include "middlebury_bounds.inc"

TEST(Middlebury, BundledTsukubaUnderBound) {
  const fs::path dir = fs::path(MCTSTEREO_DATA_DIR) / "tsukuba";
  ASSERT_TRUE(fs::exists(dir / "scene.txt")) << dir;
  int checked = 0;
  for (const Bound& b : kBounds) {
    if (std::string(b.scene) != "tsukuba") continue;
    const Scores s = score_scene(dir, b.preset);
    EXPECT_LE(s.nonocc, b.max.nonocc) << b.preset;
    EXPECT_LE(s.all, b.max.all) << b.preset;
    EXPECT_LE(s.disc, b.max.disc) << b.preset;
    ++checked;
  }
  EXPECT_GE(checked, 3);
}

TEST(Middlebury, SharedSetAverageUnderBound) {
  const fs::path root = fs::path(MCTSTEREO_SHARED_DATA_DIR) / "middlebury2003";
  if (!fs::exists(root)) GTEST_SKIP() << root << " not present: the four-scene bounds are not checked";
  for (const Bound& b : kBounds) {
    const fs::path dir = root / b.scene;
    ASSERT_TRUE(fs::exists(dir / "scene.txt")) << dir;
    const Scores s = score_scene(dir, b.preset);
    EXPECT_LE(s.nonocc, b.max.nonocc) << b.preset << " " << b.scene;
    EXPECT_LE(s.all, b.max.all) << b.preset << " " << b.scene;
    EXPECT_LE(s.disc, b.max.disc) << b.preset << " " << b.scene;
  }
}

TEST(Middlebury, AverageOfTwelveNumbersMeetsTheTargets) {
  const fs::path root = fs::path(MCTSTEREO_SHARED_DATA_DIR) / "middlebury2003";
  if (!fs::exists(root)) GTEST_SKIP() << root << " not present";
  for (const auto& [preset_name, target] : kAverageTargets) {
    double sum = 0;
    for (const char* scene : {"tsukuba", "venus", "teddy", "cones"}) {
      const Scores s = score_scene(root / scene, preset_name);
      sum += s.nonocc + s.all + s.disc;
    }
    EXPECT_LE(sum / 12.0, target) << preset_name;
  }
}

// The confidence ranks the pixels: its most confident half has at most a third of the bad pixels of
// all (measured on the bundled Tsukuba with balanced: 3.85 % of all, 1.05 % of the half).
TEST(Middlebury, ConfidentHalfOfTsukubaHasAThirdOfTheErrors) {
  const Sparsification s = sparsification(fs::path(MCTSTEREO_DATA_DIR) / "tsukuba", "balanced");
  EXPECT_GT(s.all, 1.0);  // something to rank
  EXPECT_LE(s.confident_half, s.all / 3) << s.all;
  EXPECT_LE(s.confident_half, 1.3);
}

// The same with the box margin of the realtime preset on the bundled Tsukuba: its confident half
// has under half of the errors (measured 3.58 % of 7.91 %; the four-scene average below is a
// quarter).
TEST(Middlebury, ConfidentHalfOfTsukubaHasFewerErrorsWithBoxAggregation) {
  const Sparsification s = sparsification(fs::path(MCTSTEREO_DATA_DIR) / "tsukuba", "realtime");
  EXPECT_GT(s.all, 5.0);
  EXPECT_LE(s.confident_half, s.all / 2) << s.all;
}

// The same on the four Middlebury 2003 scenes on average, for every preset; scene by scene at most
// half for band SGM (Venus, with 1.7 % bad, keeps 0.6 % in its confident half: errors the margin
// cannot see) and at most 0.55 for box aggregation (mr-mct-full keeps 1.11 % of Venus's 2.17 %).
TEST(Middlebury, ConfidentHalfHasAThirdOfTheErrors) {
  const fs::path root = fs::path(MCTSTEREO_SHARED_DATA_DIR) / "middlebury2003";
  if (!fs::exists(root)) GTEST_SKIP() << root << " not present";
  for (const std::string& preset_name : preset_names()) {
    const double per_scene = preset(preset_name).sgm() ? 0.5 : 0.55;
    double all = 0, half = 0;
    for (const char* scene : {"tsukuba", "venus", "teddy", "cones"}) {
      const Sparsification s = sparsification(root / scene, preset_name);
      // A scene with almost no errors left (Venus: under 0.5 % bad with the SGM presets) has
      // none to rank: its bound does not go below half a percent.
      EXPECT_LE(s.confident_half, std::max(per_scene * s.all, 0.5)) << preset_name << " " << scene;
      all += s.all;
      half += s.confident_half;
    }
    EXPECT_LE(half, all / 3) << preset_name;
  }
}

}  // namespace
}  // namespace mctstereo::test
