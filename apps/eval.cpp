// `mctstereo eval`.
//
// Every scene folder under DATA is read and checked first (images, ground truth, masks, ranges,
// outputs), so that a mistake costs no matching. Then per scene, per method (each --preset, then
// the OpenCV peers with --peers), per step (the unchanged pair only, or every step of the exposure
// study with --radiometric): match, score, and keep the disparity preview and error map of the
// unchanged pair for --save. The tables come last.
//
// The JSON report (--json), an object. Percentages are 0..100; a region a scene does not have,
// and any number that does not exist (avgerr without a single estimate), is null.
//   "preset": the first preset; "presets": [every preset run]; "peers": [OpenCV methods run],
//   "backend", "simd_target", "threads", "threshold" (px of the v2 numbers and the error maps),
//   "parameters": every StereoParams field of the first preset (with the flags given; the
//     scenes' own ranges replace min_disparity and num_disparities unless those were flags),
//   "scenes": one per scene: {
//     "scene", "set", "path", "width", "height",
//     "min_disparity", "num_disparities": the first preset's range,
//     "nonocc", "all", "disc", "density", "ms", "pixels": {"nonocc", "all", "disc"}: the first
//       preset's v2 numbers (percent bad > threshold) and region sizes,
//     "mask_source": "files" (nonocc from a mask file), "derived-lr-check" (nonocc derived by the
//       left-right check of the two views' ground truths) or "ground-truth-only" (no nonocc),
//     "regions": the regions the scene has, of "nonocc", "all", "disc",
//     "input": "colour" or "gray", the scene's left image as read,
//     "methods": one per method, presets first: {
//       "method", "kind" ("mctstereo" or "opencv"), "min_disparity", "num_disparities" (OpenCV:
//       rounded up to a multiple of 16), "skipped" (the reason; only when the method could not
//       run on this scene, and then nothing else follows),
//       "nonocc", "all", "disc" (v2, percent bad > threshold), "average_percent_bad" (mean of the
//       scene's v2 numbers), "density", "ms",
//       "metrics": {region: {"pixels", "invalid_pixels", "bad_0_5", "bad_1", "bad_2", "bad_4",
//         "avgerr", "rms" (px, over the pixels with an estimate), "invalid" (percent without an
//         estimate), "d1" (KITTI D1 percent)}},
//       "steps" (with --radiometric): [{"step" (label), "nonocc", "all", "disc",
//         "average_percent_bad", "d1_all"}] in the order of the study } } ],
//   "average", "average_percent_bad": the first preset's means over the scenes, as ever: "average"
//     = {"nonocc", "all", "disc", "density", "ms"} (a region's mean over the scenes that have it);
//     "average_percent_bad" = the mean of every v2 number of every scene,
//   "input": "colour", "gray" or "mixed": the scenes' left images; "colour": whether the first
//     preset's maps were made from colour (its weighted median weighs by the left view's colour;
//     matching always uses the luma),
//   "methods": [{"method", "kind", "parameters" (presets), "colour" (as above, per method), "scenes" (scored), "average": {"nonocc",
//     "all", "disc", "density", "ms", "bad_0_5", "bad_1", "bad_2", "bad_4", "avgerr", "rms",
//     "invalid", "d1" (v3 and D1 of the nonocc region), "d1_all"}, "average_percent_bad"}],
//   "radiometric" (with --radiometric): {"headline", "seed", "steps": [{"step", "kind", "amount",
//     "scores": {method: average percent bad over the scenes}}], "summary": [{"method", "kind",
//     "census" ("ct", "mct"; null for OpenCV), "baseline", "worst", "worst_step", "mean",
//     "worst_degradation", "mean_degradation"}], "by_change": {kind: {"ct", "mct"}} (mean
//     degradation of the presets of each census over the steps of that kind), "conclusion"},
//   "settings": {"cpu_model", "cores_online", "simd_target", "backend", "threads_requested",
//     "threads", "opencv_threads", "compiler", "build_type", "date" (UTC, ISO 8601),
//     "mctstereo_version", "opencv_version", "command_line"},
//   "skipped": [{"scene", "method", "reason"}]: methods that could not run on a scene.
#include "eval.hpp"

#include <unistd.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/core/version.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <functional>
#include <optional>
#include <sstream>
#include <tuple>

#include "calibration.hpp"
#include "errors.hpp"
#include "eval_metrics.hpp"
#include "input_files.hpp"
#include "io.hpp"
#include "machine_info.hpp"
#include "output_files.hpp"
#include "pair_method.hpp"
#include "peers.hpp"
#include "radiometric.hpp"
#include "statistics.hpp"

#ifndef MCTSTEREO_VERSION
#define MCTSTEREO_VERSION "unknown"
#endif

namespace mctstereo::app {

namespace fs = std::filesystem;

namespace {

constexpr const char* kEvalFooter = R"(Scores. Middlebury v2: percent of bad pixels, |d - ground truth| > 1 px (--threshold), in
the nonocc, all and disc regions (mask value 255). Middlebury v3: bad 0.5, 1, 2 and 4 px, avgerr
(mean |d - ground truth|) and rms in pixels, invalid (percent of pixels without a disparity).
KITTI D1: percent of pixels whose error is > 3 px and > 5 % of the true disparity. Pixels without
a disparity count as bad in every bad-N and D1 rate; avgerr and rms are taken over the pixels
with a disparity only, the others being counted in invalid. density is the percent of all pixels
with a disparity; ms the frame time, median of --repeat frames after one untimed frame (mctstereo:
the matcher's frame, colour conversion included; OpenCV: compute() on gray frames).

A scene folder holds a scene.txt (key=value): left, right, gt (the left view's ground truth: an 8-
or 16-bit PNG/PGM, disparity = value / gt_scale, gt_invalid (default 0) = unknown; or a PFM,
disparity = value / gt_scale (default 1), +INF = unknown), max_disp and optionally min_disp
(default 0): each scene searches min_disp .. max_disp unless --min-disparity or --num-disparities
say otherwise. masks: files of the nonocc [all [disc]] regions, or none; without an all file, all
= the pixels with ground truth. gt_right: the right view's ground truth (same formats); with
masks=none, nonocc is then derived by the left-right check of the two ground truths: a left pixel
x with ground truth d is non-occluded when the right ground truth at x - round(d) is known and
within 1 px of d. Such scenes have no disc region ('-' in the tables, null in the JSON). dmin.txt
of the Middlebury 2005/2006 sets is a crop offset for depth, not a disparity: it is not read.

--preset takes a comma-separated list (realtime,mct-full); the parameter flags apply on top of each
preset. --peers adds OpenCV StereoBM (block 9) and StereoSGBM (block 5, 3-way) on gray frames,
searching the scene's range rounded up to a multiple of 16 disparities.
--save DIR (created if needed) writes per scene SCENE_disparity.png (turbo colours over the
scene's range, black = no disparity) and SCENE_errors.png (the left image in grey, bad pixels
(> --threshold, or no disparity) red, pixels without ground truth dimmed); with several methods,
SCENE_METHOD_disparity.png and SCENE_METHOD_errors.png for all but a single preset; with
--radiometric, of the unchanged pair. Files of those names in DIR are replaced, inputs never.
--radiometric: the exposure study. For each step (none, gain, bias, gamma, vignetting, Gaussian
noise seeded by 1 + the scene's index) the right image alone is changed and every method scored
again (default: every preset); a cell is the average percent bad of the method (the mean of the
v2 numbers of every scene), and the summary gives each method's baseline, worst and mean over the
changes, and compares the CT presets with the MCT presets.
)";

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string signed_fixed(double v, int decimals) { return (v >= 0 ? "+" : "") + fixed(v, decimals); }

std::string size_text(const cv::Size& size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

std::string joined(const std::vector<std::string>& parts, const std::string& separator = ", ") {
  std::string text;
  for (const std::string& p : parts) text += (text.empty() ? "" : separator) + p;
  return text;
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// --- Scenes -------------------------------------------------------------------------------------

// No search reaches beyond min 1024 + 2048 disparities (StereoParams::validate).
constexpr int kMaxSceneDisparity = 4096;

// One scene as scene.txt describes it.
struct Scene {
  fs::path folder;
  std::string name, set;
  std::map<std::string, std::string> keys;

  bool has(const std::string& k) const {
    const auto it = keys.find(k);
    return it != keys.end() && !it->second.empty();
  }
  const std::string& key(const std::string& k) const {
    const auto it = keys.find(k);
    if (it == keys.end() || it->second.empty())
      throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + " has no '" + k + "=' line");
    return it->second;
  }
  double number(const std::string& k) const {
    const std::string& text = key(k);
    double value = 0.0;
    const std::string problem = number_problem(text, value);
    if (!problem.empty())
      throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + ": " + k + "=" + text + " " + problem);
    return value;
  }
  double number_or(const std::string& k, double fallback) const { return has(k) ? number(k) : fallback; }
  // A disparity bound (min_disp, max_disp; NaN fallback: the key is needed), within what the matcher
  // searches, so that it fits an int as written.
  double disparity_or(const std::string& k, double fallback) const {
    const double value = std::isnan(fallback) || has(k) ? number(k) : fallback;
    if (std::abs(value) > kMaxSceneDisparity)
      throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + ": " + k + "=" + key(k) + " is too " +
                         (value > 0 ? "large" : "small") + " (disparities lie in [-" +
                         std::to_string(kMaxSceneDisparity) + ", " + std::to_string(kMaxSceneDisparity) + "])");
    return value;
  }
  std::string file(const std::string& name_in_scene) const { return (folder / name_in_scene).string(); }
};

enum Region : int { kNonocc = 0, kAll = 1, kDisc = 2 };
constexpr int kRegions = 3;
constexpr const char* kRegionNames[kRegions] = {"nonocc", "all", "disc"};

// A scene read and checked, ready to be matched.
struct SceneData {
  Scene scene;
  cv::Mat left, right;  // as the matcher takes them: 8-bit gray or BGR
  cv::Mat left_gray, right_gray;
  cv::Mat ground_truth;  // CV_32F pixels, NaN where unknown
  std::array<cv::Mat, kRegions> masks;  // CV_8U, 255 = in the region; empty: the scene has no such region
  std::string mask_source;  // "files", "derived-lr-check", "ground-truth-only"
  int min_disparity = 0, num_disparities = 0;  // the scene's own range
  std::vector<std::string> files;              // every file read, which --save must not overwrite
};

template <typename T>
MapView<const T> map_view(const cv::Mat& m) {
  return {m.ptr<const T>(0), m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step[0] / sizeof(T))};
}

template <typename T>
MapView<T> mutable_map_view(cv::Mat& m) {
  return {m.ptr<T>(0), m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step[0] / sizeof(T))};
}

// A one-channel PFM file (mctstereo::decode_pfm), as Middlebury 2014 stores ground truth: top row
// first, CV_32F.
cv::Mat read_pfm(const std::string& path, const std::string& role) {
  const std::string what = role + " " + in_quotes(path);
  // Only a regular file is read (a FIFO would hang), with the program's messages for what is missing.
  const std::string bytes = read_input_file(path, role);
  try {
    const FloatMap map = decode_pfm(bytes, what);
    return cv::Mat(map.height, map.width, CV_32F, const_cast<float*>(map.values.data())).clone();
  } catch (const std::runtime_error& e) {
    throw RuntimeError(e.what());
  }
}

// Ground truth in pixels, NaN where unknown: a PFM (value / gt_scale, gt_scale 1 unless given;
// non-finite = unknown) or an 8- or 16-bit image (value / gt_scale; gt_invalid, default 0, =
// unknown). RuntimeError naming the file when it cannot be read or has the wrong size.
cv::Mat read_ground_truth(const Scene& scene, const std::string& key, const cv::Size& size, const std::string& role) {
  const std::string path = scene.file(scene.key(key));
  const bool pfm = lower_extension(path) == ".pfm";
  const double scale = pfm ? scene.number_or("gt_scale", 1.0) : scene.number("gt_scale");
  if (!(scale > 0)) throw RuntimeError("scene " + scene.name + ": gt_scale must be positive");
  cv::Mat gt;
  if (pfm) {
    gt = read_pfm(path, role);
    for (int y = 0; y < gt.rows; ++y) {
      float* row = gt.ptr<float>(y);
      for (int x = 0; x < gt.cols; ++x)
        row[x] = std::isfinite(row[x]) ? static_cast<float>(row[x] / scale) : std::numeric_limits<float>::quiet_NaN();
    }
  } else {
    // read_gray_image says clearly what is wrong with a file it cannot read, and expands palettes;
    // only a 16-bit file (KITTI style) needs a second decoding that keeps its depth.
    cv::Mat raw = read_gray_image(path, role);
    const cv::Mat deep = cv::imread(path, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE);
    if (!deep.empty() && deep.depth() == CV_16U) raw = deep;
    const double invalid = scene.number_or("gt_invalid", 0.0);
    raw.convertTo(gt, CV_32F);
    for (int y = 0; y < gt.rows; ++y) {
      float* row = gt.ptr<float>(y);
      for (int x = 0; x < gt.cols; ++x)
        row[x] = row[x] == invalid ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(row[x] / scale);
    }
  }
  if (gt.size() != size)
    throw RuntimeError(role + " " + in_quotes(path) + " is " + size_text(gt.size()) + ", the scene's images " +
                       size_text(size));
  return gt;
}

cv::Mat read_mask(const Scene& scene, const std::string& name, const cv::Size& size) {
  const std::string path = scene.file(name);
  cv::Mat mask = read_gray_image(path, "mask of scene " + scene.name);
  if (mask.size() != size)
    throw RuntimeError("mask " + in_quotes(path) + " is " + size_text(mask.size()) + ", the scene's images " +
                       size_text(size));
  return mask;
}

cv::Mat to_gray(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  return gray;
}

SceneData load_scene(const fs::path& folder) {
  SceneData s;
  Scene& scene = s.scene;
  scene.folder = folder;
  scene.keys = read_scene_file(folder / "scene.txt");
  scene.name = scene.has("scene") ? scene.keys["scene"] : folder.filename().string();
  scene.set = scene.has("set") ? scene.keys["set"] : "";
  s.files.push_back((folder / "scene.txt").string());
  if (scene.has("gt_view") && scene.key("gt_view") != "left")
    throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + ": gt_view=" + scene.key("gt_view") +
                       "; gt must be the left view's ground truth (the right view's goes in gt_right)");

  const std::string left_path = scene.file(scene.key("left")), right_path = scene.file(scene.key("right"));
  s.left = read_input_image(left_path, "left image of scene " + scene.name);
  s.right = read_input_image(right_path, "right image of scene " + scene.name);
  if (s.left.size() != s.right.size())
    throw RuntimeError("scene " + scene.name + ": left image is " + size_text(s.left.size()) + ", right image " +
                       size_text(s.right.size()));
  s.left_gray = to_gray(s.left);
  s.right_gray = to_gray(s.right);
  s.files.insert(s.files.end(), {left_path, right_path, scene.file(scene.key("gt"))});
  s.ground_truth = read_ground_truth(scene, "gt", s.left.size(), "ground truth of scene " + scene.name);

  std::vector<std::string> mask_files;
  std::istringstream mask_list(scene.has("masks") ? scene.keys["masks"] : "none");
  for (std::string m; mask_list >> m;)
    if (m != "none") mask_files.push_back(m);
  if (mask_files.size() > 3)
    throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + ": masks= names " +
                       std::to_string(mask_files.size()) + " files; at most 3 (nonocc, all, disc)");
  for (std::size_t r = 0; r < mask_files.size(); ++r) {
    s.masks[r] = read_mask(scene, mask_files[r], s.left.size());
    s.files.push_back(scene.file(mask_files[r]));
  }
  if (s.masks[kAll].empty()) {
    s.masks[kAll] = cv::Mat(s.left.size(), CV_8U);
    known_ground_truth_mask(map_view<float>(s.ground_truth), mutable_map_view<std::uint8_t>(s.masks[kAll]));
  }
  if (!mask_files.empty()) {
    s.mask_source = "files";
  } else if (scene.has("gt_right")) {
    const cv::Mat right_gt = read_ground_truth(scene, "gt_right", s.left.size(), "right ground truth of scene " +
                                                                                     scene.name);
    s.files.push_back(scene.file(scene.key("gt_right")));
    s.masks[kNonocc] = cv::Mat(s.left.size(), CV_8U);
    lr_check_nonocc_mask(map_view<float>(s.ground_truth), map_view<float>(right_gt),
                         mutable_map_view<std::uint8_t>(s.masks[kNonocc]), 1.0f);
    s.mask_source = "derived-lr-check";
  } else {
    s.mask_source = "ground-truth-only";
  }

  s.min_disparity = static_cast<int>(std::floor(scene.disparity_or("min_disp", 0.0)));
  const int max_disp = static_cast<int>(std::ceil(scene.disparity_or("max_disp", kNaN)));
  if (max_disp < s.min_disparity)
    throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + ": max_disp=" + std::to_string(max_disp) +
                       " is below min_disp=" + std::to_string(s.min_disparity));
  s.num_disparities = max_disp - s.min_disparity + 1;
  return s;
}

// --- Methods and their scores ---------------------------------------------------------------------

struct Method {
  std::string name;
  bool peer = false;
  StereoParams params;  // presets: the preset with the flags on top; the range is set per scene
};

// One method on one scene at one step of the study.
struct Score {
  bool scored = false;
  std::string skip_reason;
  int min_disparity = 0, num_disparities = 0;
  std::array<std::optional<RegionScore>, kRegions> v2;
  std::array<std::optional<RegionMetrics>, kRegions> metrics;
  double density = 0.0;
  double ms = kNaN;  // timed at the baseline step only
  // Methods with a confidence map: bad pixels of the most confident 100 / 90 / 75 / 50 % ('all').
  std::optional<std::array<double, 4>> sparsification;

  double v2_percent(int region) const { return v2[region] ? v2[region]->percent() : kNaN; }
  int v2_numbers() const {
    int n = 0;
    for (const auto& r : v2) n += r ? 1 : 0;
    return n;
  }
  double v2_sum() const {
    double sum = 0.0;
    for (const auto& r : v2)
      if (r) sum += r->percent();
    return sum;
  }
  // The Middlebury "average percent bad" of this scene alone.
  double average_percent_bad() const { return v2_numbers() > 0 ? v2_sum() / v2_numbers() : kNaN; }
};

Score score_estimate(const SceneData& s, MapView<const float> estimate, float threshold) {
  Score score;
  score.scored = true;
  const MapView<const float> gt = map_view<float>(s.ground_truth);
  for (int r = 0; r < kRegions; ++r) {
    if (s.masks[r].empty()) continue;
    const MapView<const std::uint8_t> mask = map_view<std::uint8_t>(s.masks[r]);
    score.v2[r] = bad_pixels(estimate, gt, mask, 255, threshold);
    score.metrics[r] = region_metrics(estimate, gt, mask, 255);
  }
  score.density = density_percent(estimate);
  return score;
}

// Mean over the scenes whose score has a value; NaN when none has.
template <typename F>
double mean_over(const std::vector<const Score*>& scores, F value) {
  double sum = 0.0;
  int n = 0;
  for (const Score* s : scores) {
    if (!s->scored) continue;
    const double v = value(*s);
    if (!std::isfinite(v)) continue;
    sum += v;
    ++n;
  }
  return n > 0 ? sum / n : kNaN;
}

// Middlebury's "average percent bad": the mean of every v2 number of every scene.
double average_percent_bad(const std::vector<const Score*>& scores) {
  double sum = 0.0;
  int n = 0;
  for (const Score* s : scores)
    if (s->scored) {
      sum += s->v2_sum();
      n += s->v2_numbers();
    }
  return n > 0 ? sum / n : kNaN;
}

int v2_number_count(const std::vector<const Score*>& scores) {
  int n = 0;
  for (const Score* s : scores) n += s->scored ? s->v2_numbers() : 0;
  return n;
}

std::vector<std::uint8_t> encode_error_map(const SceneData& s, MapView<const float> estimate, float threshold) {
  cv::Mat bgr(s.left.size(), CV_8UC3);
  render_error_map(estimate, map_view<float>(s.ground_truth), map_view<std::uint8_t>(s.left_gray), threshold,
                   {bgr.ptr<std::uint8_t>(0), bgr.cols, bgr.rows, static_cast<std::ptrdiff_t>(bgr.step[0])});
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", bgr, bytes)) throw RuntimeError("cannot encode the error map of scene " + s.scene.name);
  return bytes;
}

// A name that is safe as part of a file name.
std::string file_name_part(const std::string& name) {
  std::string out = name;
  for (char& c : out)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') c = '_';
  return out;
}


// "[scene 2/6 teddy] balanced, gain 0.5" on stderr: on a terminal one line rewritten in place (and
// cleared before the tables), otherwise one plain line per scene.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), terminal_(enabled && isatty(STDERR_FILENO) == 1) {}
  ~Progress() { clear(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void scene(const std::string& text) {
    scene_ = text;
    if (!enabled_) return;
    if (terminal_)
      show(scene_);
    else
      std::cerr << "mctstereo: " << scene_ << "\n" << std::flush;
  }
  void detail(const std::string& text) {
    if (terminal_) show(scene_ + ": " + text);
  }
  void clear() {
    if (!showing_) return;
    std::cerr << "\r\033[K" << std::flush;
    showing_ = false;
  }

 private:
  void show(const std::string& text) {
    std::cerr << "\r\033[Kmctstereo: " << text << std::flush;
    showing_ = true;
  }
  bool enabled_, terminal_, showing_ = false;
  std::string scene_;
};

// --- Settings -------------------------------------------------------------------------------------

// The command line of this process, arguments separated by spaces (as /proc/self/cmdline has it).
std::string command_line() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  while (!text.empty() && text.back() == '\0') text.pop_back();
  std::replace(text.begin(), text.end(), '\0', ' ');
  return text;
}

Json region_metrics_json(const RegionMetrics& m) {
  Json j = Json::object();
  j.set("pixels", m.pixels);
  j.set("invalid_pixels", m.invalid);
  j.set("bad_0_5", m.bad_percent(0));
  j.set("bad_1", m.bad_percent(1));
  j.set("bad_2", m.bad_percent(2));
  j.set("bad_4", m.bad_percent(3));
  j.set("avgerr", m.average_error());
  j.set("rms", m.rms_error());
  j.set("invalid", m.invalid_percent());
  j.set("d1", m.d1_percent());
  return j;
}

Json optional_number(double v) { return std::isfinite(v) ? Json(v) : Json(); }

// --- Reports --------------------------------------------------------------------------------------

// What a run measured, results[scene][method][step], and what it needs to be reported.
struct Evaluation {
  std::vector<Method> methods;
  std::size_t preset_count = 0;  // methods[0 .. preset_count) are presets, the others OpenCV
  std::vector<SceneData> scenes;
  std::vector<RadiometricChange> steps;
  std::size_t baseline = 0;  // the step of the unchanged pair
  std::vector<std::vector<std::vector<Score>>> results;
  float threshold = 1.0f;
  Backend backend = Backend::Cpu;
  std::string simd_target;
  int threads = 0;

  // The scores of one method at one step, scene by scene.
  std::vector<const Score*> column(std::size_t method, std::size_t step) const {
    std::vector<const Score*> c;
    for (const auto& per_scene : results) c.push_back(&per_scene[method][step]);
    return c;
  }
  std::string kind(std::size_t method) const { return methods[method].peer ? "opencv" : "mctstereo"; }
};

// The mean sparsification curve over the scenes that have one (NaN entries when none has).
std::array<double, 4> mean_sparsification(const std::vector<const Score*>& c) {
  std::array<double, 4> mean{};
  for (std::size_t i = 0; i < mean.size(); ++i)
    mean[i] = mean_over(c, [&](const Score& s) { return s.sparsification ? (*s.sparsification)[i] : kNaN; });
  return mean;
}

// One column of the Middlebury v3 / KITTI table.
struct V3Column {
  const char* header;  // in the table
  const char* key;     // in the JSON averages
  Region region;
  double (*value)(const RegionMetrics&);
};

const std::array<V3Column, 9> kV3Columns = {{
    {"bad0.5", "bad_0_5", kNonocc, [](const RegionMetrics& m) { return m.bad_percent(0); }},
    {"bad1", "bad_1", kNonocc, [](const RegionMetrics& m) { return m.bad_percent(1); }},
    {"bad2", "bad_2", kNonocc, [](const RegionMetrics& m) { return m.bad_percent(2); }},
    {"bad4", "bad_4", kNonocc, [](const RegionMetrics& m) { return m.bad_percent(3); }},
    {"avgerr", "avgerr", kNonocc, [](const RegionMetrics& m) { return m.average_error(); }},
    {"rms", "rms", kNonocc, [](const RegionMetrics& m) { return m.rms_error(); }},
    {"invalid", "invalid", kNonocc, [](const RegionMetrics& m) { return m.invalid_percent(); }},
    {"D1-noc", "d1", kNonocc, [](const RegionMetrics& m) { return m.d1_percent(); }},
    {"D1-all", "d1_all", kAll, [](const RegionMetrics& m) { return m.d1_percent(); }},
}};

double v3_value(const Score& s, const V3Column& column) {
  return s.metrics[column.region] ? column.value(*s.metrics[column.region]) : kNaN;
}

std::string v2_cells(const std::array<double, kRegions>& values) {
  std::string text;
  for (double v : values) {
    char buf[32];
    std::snprintf(buf, sizeof buf, " %8s", fixed(v, 2).c_str());
    text += buf;
  }
  return text;
}

std::array<double, kRegions> v2_values(const Score& s) { return {s.v2_percent(0), s.v2_percent(1), s.v2_percent(2)}; }

std::array<double, kRegions> v2_means(const std::vector<const Score*>& c) {
  std::array<double, kRegions> means;
  for (int r = 0; r < kRegions; ++r) means[r] = mean_over(c, [r](const Score& s) { return s.v2_percent(r); });
  return means;
}

double mean_density(const std::vector<const Score*>& c) {
  return mean_over(c, [](const Score& s) { return s.density; });
}
double mean_ms(const std::vector<const Score*>& c) {
  return mean_over(c, [](const Score& s) { return s.ms; });
}

// Whether the maps were made from colour: what the scenes' left images are ("colour", "gray" or
// "mixed"), and the presets that use the colour (the weighted median weighs by it; every other
// stage matches the luma).
std::string scene_input(const Evaluation& ev) {
  std::size_t colour = 0;
  for (const SceneData& s : ev.scenes) colour += s.left.channels() == 3;
  return colour == ev.scenes.size() ? "colour" : colour == 0 ? "gray" : "mixed";
}
bool uses_colour(const Evaluation& ev, std::size_t m) {
  return !ev.methods[m].peer && ev.methods[m].params.weighted_median && scene_input(ev) != "gray";
}
void print_input(const Evaluation& ev) {
  std::vector<std::string> colour, gray;
  for (std::size_t m = 0; m < ev.methods.size(); ++m)
    if (!ev.methods[m].peer) (uses_colour(ev, m) ? colour : gray).push_back(ev.methods[m].name);
  const std::string input = scene_input(ev);
  std::string text = "input: " + std::string(input == "mixed" ? "colour and gray" : input) + " images; maps made from ";
  if (!colour.empty()) text += "colour by " + joined(colour) + " (the weighted median weighs by colour; matching uses the luma)";
  if (!colour.empty() && !gray.empty()) text += ", from ";
  if (!gray.empty()) text += "gray (the luma) by " + joined(gray);
  std::printf("%s\n", text.c_str());
}

void print_v2_table(const Evaluation& ev) {
  const std::size_t b = ev.baseline;
  const std::string threshold = fixed(ev.threshold, 2);
  const std::string run = "backend " + std::string(to_string(ev.backend)) + ", SIMD " + ev.simd_target + ", threads " +
                          std::to_string(ev.threads);
  const int numbers = v2_number_count(ev.column(0, b));
  const char* plural = numbers == 1 ? "" : "s";
  if (ev.methods.size() == 1) {
    // The layout of a single preset stays as it always was.
    std::printf("%-16s %8s %8s %8s %8s %9s\n", "scene", "nonocc", "all", "disc", "density", "ms");
    for (std::size_t si = 0; si < ev.scenes.size(); ++si) {
      const Score& s = ev.results[si][0][b];
      std::printf("%-16s%s %8.1f %9.1f\n", ev.scenes[si].scene.name.c_str(), v2_cells(v2_values(s)).c_str(), s.density,
                  s.ms);
    }
    const std::vector<const Score*> c = ev.column(0, b);
    std::printf("%-16s%s %8.1f %9.1f\n", "average", v2_cells(v2_means(c)).c_str(), mean_density(c), mean_ms(c));
    std::printf("average percent bad (%d number%s, > %s px): %.2f; preset %s, %s\n", numbers, plural,
                threshold.c_str(), average_percent_bad(c), ev.methods[0].name.c_str(), run.c_str());
    return;
  }
  std::printf("%-16s %-18s %8s %8s %8s %8s %9s\n", "scene", "method", "nonocc", "all", "disc", "density", "ms");
  for (std::size_t si = 0; si < ev.scenes.size(); ++si)
    for (std::size_t m = 0; m < ev.methods.size(); ++m) {
      const Score& s = ev.results[si][m][b];
      const char* scene = ev.scenes[si].scene.name.c_str();
      const char* method = ev.methods[m].name.c_str();
      if (s.scored)
        std::printf("%-16s %-18s%s %8.1f %9.1f\n", scene, method, v2_cells(v2_values(s)).c_str(), s.density, s.ms);
      else
        std::printf("%-16s %-18s %8s %8s %8s %8s %9s  (%s)\n", scene, method, "-", "-", "-", "-", "-",
                    s.skip_reason.c_str());
    }
  std::string averages;
  for (std::size_t m = 0; m < ev.methods.size(); ++m) {
    const std::vector<const Score*> c = ev.column(m, b);
    std::printf("%-16s %-18s%s %8s %9s\n", "average", ev.methods[m].name.c_str(), v2_cells(v2_means(c)).c_str(),
                fixed(mean_density(c), 1).c_str(), fixed(mean_ms(c), 1).c_str());
    averages += (m ? ", " : "") + ev.methods[m].name + " " + fixed(average_percent_bad(c), 2);
  }
  std::printf("average percent bad (%d number%s each, > %s px): %s; %s\n", numbers, plural, threshold.c_str(),
              averages.c_str(), run.c_str());
}

void print_v3_table(const Evaluation& ev) {
  std::printf("\nMiddlebury v3 (nonocc region) and KITTI D1 (nonocc, all):\n%-16s %-18s", "scene", "method");
  for (const V3Column& column : kV3Columns) std::printf(" %7s", column.header);
  std::printf("\n");
  const auto row = [](const std::string& scene, const std::string& method, const auto& value) {
    std::printf("%-16s %-18s", scene.c_str(), method.c_str());
    for (const V3Column& column : kV3Columns) std::printf(" %7s", fixed(value(column), 2).c_str());
    std::printf("\n");
  };
  for (std::size_t si = 0; si < ev.scenes.size(); ++si)
    for (std::size_t m = 0; m < ev.methods.size(); ++m) {
      const Score& s = ev.results[si][m][ev.baseline];
      if (s.scored)
        row(ev.scenes[si].scene.name, ev.methods[m].name, [&](const V3Column& column) { return v3_value(s, column); });
    }
  if (ev.scenes.size() > 1)
    for (std::size_t m = 0; m < ev.methods.size(); ++m) {
      const std::vector<const Score*> c = ev.column(m, ev.baseline);
      row("average", ev.methods[m].name, [&](const V3Column& column) {
        return mean_over(c, [&](const Score& s) { return v3_value(s, column); });
      });
    }
  std::printf("bad-N and D1 count pixels without a disparity as bad; avgerr and rms (px) cover the pixels with one, "
              "invalid the others.\n");

  std::vector<std::string> derived, ground_truth_only;
  for (const SceneData& s : ev.scenes) {
    if (s.mask_source == "derived-lr-check") derived.push_back(s.scene.name);
    if (s.mask_source == "ground-truth-only") ground_truth_only.push_back(s.scene.name);
  }
  if (!derived.empty())
    std::printf("masks of %s: nonocc derived by the left-right check of the two views' ground truths (right ground "
                "truth at x - round(d) known and within 1 px of d), all = pixels with ground truth, no disc mask "
                "('-').\n",
                joined(derived).c_str());
  if (!ground_truth_only.empty())
    std::printf("masks of %s: none and no right ground truth: all = pixels with ground truth, no nonocc or disc "
                "('-').\n",
                joined(ground_truth_only).c_str());
}

// The sparsification curves of the methods that have a confidence map.
void print_sparsification_table(const Evaluation& ev) {
  std::vector<std::size_t> with;
  for (std::size_t m = 0; m < ev.methods.size(); ++m)
    for (std::size_t si = 0; si < ev.scenes.size(); ++si)
      if (ev.results[si][m][ev.baseline].sparsification) {
        with.push_back(m);
        break;
      }
  if (with.empty()) return;
  std::printf("\nSparsification ('all' region): percent bad (> %s px) of the most confident pixels with ground truth\n"
              "%-16s %-18s %7s %7s %7s %7s\n",
              fixed(ev.threshold, 2).c_str(), "scene", "method", "100%", "90%", "75%", "50%");
  const auto row = [](const std::string& scene, const std::string& method, const std::array<double, 4>& v) {
    std::printf("%-16s %-18s %7s %7s %7s %7s\n", scene.c_str(), method.c_str(), fixed(v[0], 2).c_str(),
                fixed(v[1], 2).c_str(), fixed(v[2], 2).c_str(), fixed(v[3], 2).c_str());
  };
  for (std::size_t si = 0; si < ev.scenes.size(); ++si)
    for (std::size_t m : with)
      if (const auto& c = ev.results[si][m][ev.baseline].sparsification) row(ev.scenes[si].scene.name, ev.methods[m].name, *c);
  if (ev.scenes.size() > 1)
    for (std::size_t m : with) row("average", ev.methods[m].name, mean_sparsification(ev.column(m, ev.baseline)));
  std::printf("the confidence (Matcher::confidence, docs/PIPELINE.md) orders the pixels; OpenCV's matchers have "
              "none.\n");
}

std::string census_label(const Method& m) {
  if (m.peer) return "-";
  const std::string side = std::to_string(m.params.census_window);
  return std::string(m.params.census == CensusKind::Census ? "CT " : "MCT ") + side + "x" + side;
}

// study[m][k]: the average percent bad of method m over the scenes at step k.
using StudyScores = std::vector<std::vector<double>>;

// The table of steps x methods; its "steps" JSON block.
Json print_study_table(const Evaluation& ev, const StudyScores& study) {
  const std::vector<RadiometricChange>& steps = ev.steps;
  const std::vector<Method>& methods = ev.methods;
  std::printf("\nExposure study: the right image changed, the left one not; cell = average percent bad (mean of the "
              "%d v2 numbers, > %s px)\n%-16s",
              v2_number_count(ev.column(0, ev.baseline)), fixed(ev.threshold, 2).c_str(), "step");
  std::vector<int> widths;
  for (const Method& m : methods) {
    widths.push_back(std::max<int>(8, static_cast<int>(m.name.size())));
    std::printf(" %*s", widths.back(), m.name.c_str());
  }
  std::printf("\n");
  Json steps_json = Json::array();
  for (std::size_t k = 0; k < steps.size(); ++k) {
    std::printf("%-16s", steps[k].label().c_str());
    Json scores = Json::object();
    for (std::size_t m = 0; m < methods.size(); ++m) {
      std::printf(" %*s", widths[m], fixed(study[m][k], 2).c_str());
      scores.set(methods[m].name, optional_number(study[m][k]));
    }
    std::printf("\n");
    Json j = Json::object();
    j.set("step", steps[k].label());
    j.set("kind", radiometric_kind_name(steps[k].kind));
    j.set("amount", steps[k].amount);
    j.set("scores", std::move(scores));
    steps_json.push_back(std::move(j));
  }
  return steps_json;
}

// Each method's degradation from the baseline, printed and into `summary_json`.
std::vector<Degradation> print_degradation(const Evaluation& ev, const StudyScores& study, Json& summary_json) {
  const std::vector<Method>& methods = ev.methods;
  std::printf("\n%-18s %-8s %9s %9s %-16s %9s %9s %9s\n", "method", "census", "baseline", "worst", "worst step", "mean",
              "worst+", "mean+");
  std::vector<Degradation> degradation;
  for (std::size_t m = 0; m < methods.size(); ++m) {
    const Degradation d = degradation.emplace_back(summarize_degradation(study[m], ev.baseline));
    const std::string worst_step = ev.steps[d.worst_step].label();
    std::printf("%-18s %-8s %9s %9s %-16s %9s %9s %9s\n", methods[m].name.c_str(), census_label(methods[m]).c_str(),
                fixed(d.baseline, 2).c_str(), fixed(d.worst, 2).c_str(), worst_step.c_str(), fixed(d.mean, 2).c_str(),
                signed_fixed(d.worst_degradation, 2).c_str(), signed_fixed(d.mean_degradation, 2).c_str());
    Json j = Json::object();
    j.set("method", methods[m].name);
    j.set("kind", ev.kind(m));
    j.set("census", methods[m].peer ? Json() : Json(methods[m].params.census == CensusKind::Census ? "ct" : "mct"));
    j.set("baseline", optional_number(d.baseline));
    j.set("worst", optional_number(d.worst));
    j.set("worst_step", worst_step);
    j.set("mean", optional_number(d.mean));
    j.set("worst_degradation", optional_number(d.worst_degradation));
    j.set("mean_degradation", optional_number(d.mean_degradation));
    summary_json.push_back(std::move(j));
  }
  std::printf("worst+, mean+: points of percent bad above the baseline (the unchanged pair); mean over the %zu "
              "changes.\n",
              ev.steps.size() - 1);
  return degradation;
}

// The presets of one census variant in the study: each number is the mean over its presets.
struct CensusGroup {
  std::vector<std::size_t> members;
  double mean_degradation = 0.0, worst_degradation = 0.0;
  std::string names;
};

// The CT presets against the MCT presets: the conclusion, printed and returned; by kind of change
// (each group's mean of score - baseline over the steps of that kind) into `by_change`.
std::string compare_census_variants(const Evaluation& ev, const StudyScores& study,
                                    const std::vector<Degradation>& degradation, Json& by_change) {
  const std::vector<Method>& methods = ev.methods;
  std::array<CensusGroup, 2> groups;  // 0: CT, 1: MCT
  for (std::size_t m = 0; m < ev.preset_count; ++m)
    groups[methods[m].params.census == CensusKind::Census ? 0 : 1].members.push_back(m);
  for (CensusGroup& g : groups)
    for (std::size_t m : g.members) {
      g.mean_degradation += degradation[m].mean_degradation / g.members.size();
      g.worst_degradation += degradation[m].worst_degradation / g.members.size();
      g.names += (g.names.empty() ? "" : ", ") + methods[m].name;
    }
  if (groups[0].members.empty() || groups[1].members.empty()) {
    const std::string conclusion = std::string("Only ") + (groups[0].members.empty() ? "MCT" : "CT") +
                                   " presets were run: no comparison of the census variants (run every preset, or "
                                   "list CT and MCT presets in --preset).";
    std::printf("%s\n", conclusion.c_str());
    return conclusion;
  }
  const bool mct_better = groups[1].mean_degradation < groups[0].mean_degradation;
  const CensusGroup& better = groups[mct_better ? 1 : 0];
  const CensusGroup& worse = groups[mct_better ? 0 : 1];
  const std::string conclusion =
      std::string(mct_better ? "MCT" : "CT") + " presets (" + better.names + ") degrade least: " +
      fixed(better.mean_degradation, 2) + " points of percent bad on average over the changes (worst " +
      fixed(better.worst_degradation, 2) + "), against " + fixed(worse.mean_degradation, 2) + " (worst " +
      fixed(worse.worst_degradation, 2) + ") for the " + (mct_better ? "CT" : "MCT") + " presets (" + worse.names +
      "): " + fixed(worse.mean_degradation - better.mean_degradation, 2) + " points less on average, and " +
      fixed(std::fabs(worse.worst_degradation - better.worst_degradation), 2) +
      (better.worst_degradation <= worse.worst_degradation ? " less" : " more") + " at the worst step.";
  std::string by_kind;
  for (RadiometricKind kind : {RadiometricKind::Gain, RadiometricKind::Bias, RadiometricKind::Gamma,
                               RadiometricKind::Vignetting, RadiometricKind::Noise}) {
    std::array<double, 2> mean{0.0, 0.0};
    int count = 0;
    for (std::size_t k = 0; k < ev.steps.size(); ++k) {
      if (ev.steps[k].kind != kind) continue;
      ++count;
      for (int g = 0; g < 2; ++g)
        for (std::size_t m : groups[g].members)
          mean[g] += (study[m][k] - study[m][ev.baseline]) / groups[g].members.size();
    }
    if (count == 0) continue;
    Json j = Json::object();
    j.set("ct", mean[0] / count);
    j.set("mct", mean[1] / count);
    by_change.set(radiometric_kind_name(kind), std::move(j));
    by_kind += (by_kind.empty() ? "" : ", ") + std::string(radiometric_kind_name(kind)) + " " +
               signed_fixed(mean[0] / count, 2) + " / " + signed_fixed(mean[1] / count, 2);
  }
  std::printf("mean degradation by change, CT / MCT presets: %s\n", by_kind.c_str());
  std::printf("%s\n", conclusion.c_str());
  return conclusion;
}

// The exposure study: the table of steps x methods, each method's degradation, and the CT presets
// against the MCT presets. Returns the "radiometric" block of the JSON report.
Json report_study(const Evaluation& ev) {
  StudyScores study(ev.methods.size(), std::vector<double>(ev.steps.size()));
  for (std::size_t m = 0; m < ev.methods.size(); ++m)
    for (std::size_t k = 0; k < ev.steps.size(); ++k) study[m][k] = average_percent_bad(ev.column(m, k));

  Json steps_json = print_study_table(ev, study);
  Json summary_json = Json::array();
  const std::vector<Degradation> degradation = print_degradation(ev, study, summary_json);
  Json by_change = Json::object();
  const std::string conclusion = compare_census_variants(ev, study, degradation, by_change);

  Json study_json = Json::object();
  study_json.set("headline", "average percent bad: the mean of the v2 numbers (bad > threshold in nonocc, all, disc) "
                             "of every scene");
  study_json.set("seed", "1 + the scene's index (0-based, scenes in path order)");
  study_json.set("steps", std::move(steps_json));
  study_json.set("summary", std::move(summary_json));
  study_json.set("by_change", std::move(by_change));
  study_json.set("conclusion", conclusion);
  return study_json;
}

// {"fractions": [1, 0.9, 0.75, 0.5], "percent_bad": [...]}.
Json sparsification_json(const std::array<double, 4>& curve) {
  Json j = Json::object(), fractions = Json::array(), bad = Json::array();
  for (std::size_t i = 0; i < curve.size(); ++i) {
    fractions.push_back(kSparsificationFractions[i]);
    bad.push_back(optional_number(curve[i]));
  }
  j.set("fractions", std::move(fractions));
  j.set("percent_bad", std::move(bad));
  return j;
}

Json scene_json(const Evaluation& ev, std::size_t si) {
  const SceneData& s = ev.scenes[si];
  const Score& first = ev.results[si][0][ev.baseline];
  Json j = Json::object();
  j.set("scene", s.scene.name);
  j.set("set", s.scene.set);
  j.set("path", s.scene.folder.string());
  j.set("width", s.left.cols);
  j.set("height", s.left.rows);
  j.set("min_disparity", first.min_disparity);
  j.set("num_disparities", first.num_disparities);
  for (int r = 0; r < kRegions; ++r) j.set(kRegionNames[r], optional_number(first.v2_percent(r)));
  j.set("density", first.density);
  j.set("ms", first.ms);
  Json pixels = Json::object();
  for (int r = 0; r < kRegions; ++r) pixels.set(kRegionNames[r], first.v2[r] ? Json(first.v2[r]->pixels) : Json());
  j.set("pixels", std::move(pixels));
  j.set("mask_source", s.mask_source);
  j.set("input", s.left.channels() == 3 ? "colour" : "gray");
  Json regions = Json::array();
  for (int r = 0; r < kRegions; ++r)
    if (!s.masks[r].empty()) regions.push_back(kRegionNames[r]);
  j.set("regions", std::move(regions));
  Json per_method = Json::array();
  for (std::size_t m = 0; m < ev.methods.size(); ++m) {
    const Score& score = ev.results[si][m][ev.baseline];
    Json e = Json::object();
    e.set("method", ev.methods[m].name);
    e.set("kind", ev.kind(m));
    if (!score.scored) {
      e.set("skipped", score.skip_reason);
      per_method.push_back(std::move(e));
      continue;
    }
    e.set("min_disparity", score.min_disparity);
    e.set("num_disparities", score.num_disparities);
    for (int r = 0; r < kRegions; ++r) e.set(kRegionNames[r], optional_number(score.v2_percent(r)));
    e.set("average_percent_bad", optional_number(score.average_percent_bad()));
    e.set("density", score.density);
    e.set("ms", score.ms);
    Json metrics = Json::object();
    for (int r = 0; r < kRegions; ++r)
      if (score.metrics[r]) metrics.set(kRegionNames[r], region_metrics_json(*score.metrics[r]));
    e.set("metrics", std::move(metrics));
    if (score.sparsification) e.set("sparsification", sparsification_json(*score.sparsification));
    if (ev.steps.size() > 1) {
      Json per_step = Json::array();
      for (std::size_t k = 0; k < ev.steps.size(); ++k) {
        const Score& t = ev.results[si][m][k];
        Json st = Json::object();
        st.set("step", ev.steps[k].label());
        for (int r = 0; r < kRegions; ++r) st.set(kRegionNames[r], optional_number(t.v2_percent(r)));
        st.set("average_percent_bad", optional_number(t.average_percent_bad()));
        st.set("d1_all", optional_number(v3_value(t, kV3Columns.back())));
        per_step.push_back(std::move(st));
      }
      e.set("steps", std::move(per_step));
    }
    per_method.push_back(std::move(e));
  }
  j.set("methods", std::move(per_method));
  return j;
}

// A method's means over the scenes: the v2 numbers, density and ms, and with `v3` the v3 and D1 columns.
Json average_json(const Evaluation& ev, std::size_t m, bool v3) {
  const std::vector<const Score*> c = ev.column(m, ev.baseline);
  const std::array<double, kRegions> v2 = v2_means(c);
  Json a = Json::object();
  for (int r = 0; r < kRegions; ++r) a.set(kRegionNames[r], optional_number(v2[r]));
  a.set("density", optional_number(mean_density(c)));
  a.set("ms", optional_number(mean_ms(c)));
  if (v3)
    for (const V3Column& column : kV3Columns)
      a.set(column.key, optional_number(mean_over(c, [&](const Score& s) { return v3_value(s, column); })));
  if (std::any_of(c.begin(), c.end(), [](const Score* s) { return s->sparsification.has_value(); }))
    a.set("sparsification", sparsification_json(mean_sparsification(c)));
  return a;
}

Json settings_json(const Evaluation& ev, int threads_requested) {
  Json settings = Json::object();
  settings.set("cpu_model", cpu_model());
  settings.set("cores_online", static_cast<long>(sysconf(_SC_NPROCESSORS_ONLN)));
  settings.set("simd_target", ev.simd_target);
  settings.set("backend", to_string(ev.backend));
  settings.set("threads_requested", threads_requested);
  settings.set("threads", ev.threads);
  settings.set("opencv_threads", cv::getNumThreads());
  settings.set("compiler", compiler_version());
  settings.set("build_type", build_type());
  settings.set("date", utc_date());
  settings.set("mctstereo_version", MCTSTEREO_VERSION);
  settings.set("opencv_version", CV_VERSION);
  settings.set("command_line", command_line());
  return settings;
}

}  // namespace

std::map<std::string, std::string> read_scene_file(const fs::path& path) {
  std::istringstream in(read_input_file(path.string(), "scene"));
  std::map<std::string, std::string> keys;
  std::string line;
  while (std::getline(in, line)) {
    line = trim(line);
    if (line.empty() || line[0] == '#') continue;
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    keys[trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
  }
  return keys;
}

SceneSummary read_scene(const fs::path& folder) {
  const SceneData s = load_scene(folder);
  return {s.scene.name, s.left.cols, s.left.rows, s.min_disparity, s.num_disparities, s.mask_source};
}

ScenePair read_scene_pair(const fs::path& folder) {
  const SceneData s = load_scene(folder);
  const cv::Mat& nonocc = s.masks[kNonocc].empty() ? s.masks[kAll] : s.masks[kNonocc];
  return {s.scene.name, s.left, s.right, s.ground_truth, nonocc, s.min_disparity, s.num_disparities};
}

std::vector<fs::path> find_scene_folders(const fs::path& data) {
  std::error_code ec;
  if (!fs::exists(data, ec)) throw RuntimeError("data folder " + in_quotes(data) + " does not exist");
  if (!fs::is_directory(data, ec)) throw RuntimeError("data folder " + in_quotes(data) + " is not a folder");
  std::vector<fs::path> folders;
  if (fs::is_regular_file(data / "scene.txt", ec)) folders.push_back(data);
  for (auto it = fs::recursive_directory_iterator(data, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it->is_directory(ec) && fs::is_regular_file(it->path() / "scene.txt", ec)) folders.push_back(it->path());
  }
  if (ec) throw RuntimeError("cannot list " + in_quotes(data) + ": " + ec.message());
  std::sort(folders.begin(), folders.end());
  return folders;
}

EvalCommand::EvalCommand(CLI::App& parent)
    : command_(parent.add_subcommand("eval", "score presets (and OpenCV) on Middlebury scenes: v2, v3, KITTI D1")),
      parameters_(*command_) {
  CLI::App& app = *command_;
  app.footer(kEvalFooter);
  std::string presets;
  for (const std::string& name : preset_names())
    presets += "\n  " + name + ": " + std::string(preset_description(name));
  app.get_option("--preset")
      ->description("named parameter set, applied before the other parameter flags (default balanced; with "
                    "--radiometric every preset); a comma-separated list scores each:" +
                    presets);
  app.add_option("DATA", data_, "a scene folder, or a folder searched recursively for scene folders")->required();
  app.add_option("--json", json_, "also write every score, the masks' source, the settings (and the study) to this "
                                  "JSON file");
  app.add_option("--threshold", threshold_, "a pixel is bad when |d - ground truth| exceeds this, pixels")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  app.add_option("--repeat", repeat_, "time N frames per scene (after one untimed frame) and report the median")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  app.add_flag("--peers", peers_, "also score OpenCV StereoBM and StereoSGBM on the same scenes (gray frames)");
  app.add_option("--save", save_dir_, "write each scene's disparity preview and error map (PNG) into this folder");
  app.add_flag("--radiometric", radiometric_,
               "exposure study: change the right image (gain, bias, gamma, vignetting, noise) and score again");
  app.add_flag("-q,--quiet", quiet_, "no progress line on stderr");
  run_flags_.add_to(app);
}

StereoParams EvalCommand::resolve_preset(const std::string& name) const {
  // ParameterFlags applies its flags on top of the preset bound to --preset: setting that
  // option's value to one name of the list gives the preset with the flags, as for a single one.
  command_->get_option("--preset")->default_val(name);
  return parameters_.resolve();
}

namespace {

// --- The units of a run -----------------------------------------------------------------------------

// The preset names of --preset's comma-separated list, each once; UsageError for an empty name.
std::vector<std::string> preset_list_of(const std::string& text) {
  std::vector<std::string> names;
  std::stringstream list(text);
  for (std::string name; std::getline(list, name, ',');) {
    name = trim(name);
    if (name.empty()) throw UsageError("--preset: empty name in the list '" + text + "'");
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  }
  if (names.empty()) throw UsageError("--preset: no preset given");
  return names;
}

// The files of --save: SCENE[_METHOD]_{disparity,errors}.png in `dir`.
struct SavePlan {
  std::string dir;
  std::vector<std::string> scene_names;  // file_name_part of each scene's name

  std::string path(const Evaluation& ev, std::size_t scene, std::size_t method, const std::string& what) const {
    const bool plain = method < ev.preset_count && ev.preset_count == 1;
    const std::string stem = scene_names[scene] + (plain ? "" : "_" + file_name_part(ev.methods[method].name));
    return (fs::path(dir) / (stem + "_" + what + ".png")).string();
  }
};

// Checks the files of --save before anything is matched: one name per scene, none an input, none
// the same as another output.
SavePlan plan_saving(const Evaluation& ev, const std::string& dir, const std::string& json,
                     const std::vector<std::string>& inputs) {
  SavePlan plan{dir, {}};
  for (const SceneData& s : ev.scenes) plan.scene_names.push_back(file_name_part(s.scene.name));
  if (dir.empty()) return plan;
  for (std::size_t i = 0; i < ev.scenes.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (plan.scene_names[i] == plan.scene_names[j])
        throw UsageError("--save: scenes " + in_quotes(ev.scenes[j].scene.folder) + " and " +
                         in_quotes(ev.scenes[i].scene.folder) + " are both named '" + ev.scenes[i].scene.name +
                         "': their files would overwrite each other");
  std::error_code ec;
  std::vector<std::pair<std::string, std::string>> outputs{{"--json", json}};
  for (std::size_t i = 0; i < ev.scenes.size(); ++i)
    for (std::size_t m = 0; m < ev.methods.size(); ++m)
      for (const char* what : {"disparity", "errors"}) {
        const std::string path = plan.path(ev, i, m, what);
        if (fs::is_directory(dir, ec)) check_output_path(path, inputs, "--save file");
        outputs.push_back({"--save", path});
      }
  check_distinct_outputs(outputs);
  return plan;
}

// The right image of every step of the study, colour and gray, changed once and matched by every
// method. The noise's seed depends on the scene only, so it is the same for every method and amount.
std::pair<std::vector<cv::Mat>, std::vector<cv::Mat>> right_images(const SceneData& s,
                                                                   const std::vector<RadiometricChange>& steps,
                                                                   std::uint32_t seed) {
  std::vector<cv::Mat> right(steps.size()), right_gray(steps.size());
  for (std::size_t k = 0; k < steps.size(); ++k) {
    if (steps[k].kind == RadiometricKind::Identity) {
      right[k] = s.right;
      right_gray[k] = s.right_gray;
      continue;
    }
    right[k] = s.right.clone();
    apply_radiometric(steps[k], right[k].data, right[k].cols, right[k].rows,
                      static_cast<std::ptrdiff_t>(right[k].step[0]), right[k].channels(), seed);
    right_gray[k] = to_gray(right[k]);
  }
  return {right, right_gray};
}

// What the loop over scenes and methods needs besides the evaluation.
struct RunContext {
  const RunFlags* flags = nullptr;
  int repeat = 1;
  std::optional<int> min_disparity, num_disparities;  // --min-disparity, --num-disparities when given
  SavePlan save;
  std::vector<std::pair<std::string, std::vector<std::uint8_t>>> saved;  // --save: path, bytes
  Json skipped = Json::array();  // the peers that could not match a scene, and why

  // The range every method searches on a scene: the scene's own, or the flags' where given.
  std::pair<int, int> range(const SceneData& s) const {
    return {min_disparity.value_or(s.min_disparity), num_disparities.value_or(s.num_disparities)};
  }
  StereoParams params(const Method& m, const SceneData& s) const {
    StereoParams p = m.params;
    std::tie(p.min_disparity, p.num_disparities) = range(s);
    return p;
  }
};

// Scores `method` on scene `si` at every step; at the baseline step it is timed (one untimed frame,
// then `repeat` timed ones) and its files for --save are kept.
void score_method(Evaluation& ev, std::size_t si, std::size_t mi, PairMethod& method,
                  const std::vector<cv::Mat>& right, const std::vector<cv::Mat>& right_gray,
                  const std::function<void(std::size_t)>& detail, RunContext& run) {
  const SceneData& s = ev.scenes[si];
  for (std::size_t k = 0; k < ev.steps.size(); ++k) {
    detail(k);
    const int frames = k == ev.baseline ? run.repeat + 1 : 1;
    std::vector<double> frame_ms;
    const PairViews views{s.left, right[k], s.left_gray, right_gray[k]};
    for (int frame = 0; frame < frames; ++frame) {
      method.compute(views);
      if (frame > 0) frame_ms.push_back(method.frame_ms());
    }
    const MapView<const float> estimate = method.disparity();
    Score& score = ev.results[si][mi][k] = score_estimate(s, estimate, ev.threshold);
    if (method.confidence().data != nullptr)
      score.sparsification = sparsification_curve(estimate, map_view<float>(s.ground_truth), method.confidence(),
                                                  map_view<std::uint8_t>(s.masks[kAll]), 255, ev.threshold);
    score.min_disparity = method.min_disparity;
    score.num_disparities = method.num_disparities;
    if (k != ev.baseline) continue;
    score.ms = median(frame_ms);
    if (run.save.dir.empty()) continue;
    const std::string path = run.save.path(ev, si, mi, "disparity");
    run.saved.push_back({path, method.preview(path)});
    run.saved.push_back({run.save.path(ev, si, mi, "errors"), encode_error_map(s, estimate, ev.threshold)});
  }
}

// The OpenCV peer of that name searching the range, and why it cannot match the scene ("" if it can).
std::pair<Peer, std::string> peer_for(const std::string& name, const SceneData& s, std::pair<int, int> range) {
  Peer peer;
  for (Peer& p : make_peers(range.first, range.second))
    if (p.name == name) peer = p;
  std::string reason = peer_unsupported_reason(peer, s.left.cols);
  return {peer, reason};
}

// Scores method mi on scene si at every step: a preset through a Matcher, a peer unless it cannot
// match the scene (then a note on stderr and in the report).
void score_scene_method(Evaluation& ev, std::size_t si, std::size_t mi, const std::vector<cv::Mat>& right,
                        const std::vector<cv::Mat>& right_gray, RunContext& run, Progress& progress) {
  const SceneData& s = ev.scenes[si];
  const Method& method = ev.methods[mi];
  const auto detail = [&](std::size_t k) {
    std::string text = method.name + " (" + std::to_string(mi + 1) + "/" + std::to_string(ev.methods.size()) + ")";
    if (ev.steps.size() > 1) text += ", " + ev.steps[k].label();
    progress.detail(text);
  };
  if (!method.peer) {
    // Every preset scores its confidence map too (box presets make it only when asked).
    PresetMethod preset(run.flags->make_matcher(s.left.cols, s.left.rows, run.params(method, s), false, true));
    ev.backend = preset.matcher().backend();  // what --backend auto resolved to
    ev.simd_target = preset.matcher().simd_target();
    ev.threads = preset.matcher().threads();
    score_method(ev, si, mi, preset, right, right_gray, detail, run);
    return;
  }
  const auto range = run.range(s);
  auto [peer, reason] = peer_for(method.name, s, range);
  if (reason.empty()) {
    PeerMethod matcher(std::move(peer), range.first, range.second);
    score_method(ev, si, mi, matcher, right, right_gray, detail, run);
    return;
  }
  progress.clear();
  std::cerr << "mctstereo: note: skipping " << method.name << " on scene " << s.scene.name << ": " << reason << "\n";
  Json j = Json::object();
  j.set("scene", s.scene.name);
  j.set("method", method.name);
  j.set("reason", reason);
  run.skipped.push_back(std::move(j));
  for (Score& score : ev.results[si][mi]) score.skip_reason = reason;
}

// Matches and scores every scene with every method at every step of the study.
void score_scenes(Evaluation& ev, RunContext& run, bool quiet) {
  ev.results.assign(ev.scenes.size(),
                    std::vector<std::vector<Score>>(ev.methods.size(), std::vector<Score>(ev.steps.size())));
  Progress progress(!quiet);
  for (std::size_t si = 0; si < ev.scenes.size(); ++si) {
    const SceneData& s = ev.scenes[si];
    progress.scene("scene " + std::to_string(si + 1) + "/" + std::to_string(ev.scenes.size()) + " " + s.scene.name +
                   " (" + size_text(s.left.size()) + ", disparities " + std::to_string(s.min_disparity) + ".." +
                   std::to_string(s.min_disparity + s.num_disparities - 1) + ")");
    const auto [right, right_gray] = right_images(s, ev.steps, static_cast<std::uint32_t>(1 + si));
    for (std::size_t mi = 0; mi < ev.methods.size(); ++mi)
      score_scene_method(ev, si, mi, right, right_gray, run, progress);
  }
  progress.clear();
}

Json method_json(const Evaluation& ev, std::size_t m) {
  const std::vector<const Score*> c = ev.column(m, ev.baseline);
  Json j = Json::object();
  j.set("method", ev.methods[m].name);
  j.set("kind", ev.kind(m));
  if (!ev.methods[m].peer) j.set("parameters", parameters_json(ev.methods[m].params));
  j.set("colour", uses_colour(ev, m));
  j.set("scenes", static_cast<int>(std::count_if(c.begin(), c.end(), [](const Score* s) { return s->scored; })));
  j.set("average", average_json(ev, m, true));
  j.set("average_percent_bad", optional_number(average_percent_bad(c)));
  return j;
}

// The --json report of a finished evaluation; `study`: the exposure study's part, or null.
Json json_report(const Evaluation& ev, Backend backend, int threads_requested, const Json* study, Json skipped) {
  const std::vector<Method>& methods = ev.methods;
  Json report = Json::object();
  report.set("preset", methods[0].name);
  Json presets = Json::array(), peers = Json::array();
  for (const Method& m : methods) (m.peer ? peers : presets).push_back(m.name);
  report.set("presets", std::move(presets));
  report.set("peers", std::move(peers));
  report.set("backend", to_string(backend));
  report.set("simd_target", ev.simd_target);
  report.set("threads", ev.threads);
  report.set("threshold", static_cast<double>(ev.threshold));
  // The scenes' own ranges replace these two fields unless they were given as flags.
  report.set("parameters", parameters_json(methods[0].params));
  Json scenes_json = Json::array();
  for (std::size_t si = 0; si < ev.scenes.size(); ++si) scenes_json.push_back(scene_json(ev, si));
  report.set("scenes", std::move(scenes_json));
  report.set("average", average_json(ev, 0, false));
  report.set("average_percent_bad", optional_number(average_percent_bad(ev.column(0, ev.baseline))));
  report.set("input", scene_input(ev));
  report.set("colour", uses_colour(ev, 0));
  Json methods_json = Json::array();
  for (std::size_t m = 0; m < methods.size(); ++m) methods_json.push_back(method_json(ev, m));
  report.set("methods", std::move(methods_json));
  if (study != nullptr) report.set("radiometric", *study);
  report.set("settings", settings_json(ev, threads_requested));
  report.set("skipped", std::move(skipped));
  return report;
}

// Reads and checks every scene under `data` into ev.scenes; the files they read.
std::vector<std::string> load_scenes(Evaluation& ev, const std::string& data) {
  const std::vector<fs::path> folders = find_scene_folders(data);
  if (folders.empty())
    throw RuntimeError("no scene under " + in_quotes(data) + ": a scene folder holds a scene.txt (see data/README.md)");
  std::vector<std::string> inputs;
  for (const fs::path& folder : folders) {
    ev.scenes.push_back(load_scene(folder));
    inputs.insert(inputs.end(), ev.scenes.back().files.begin(), ev.scenes.back().files.end());
  }
  return inputs;
}

// The steps of the study (without --radiometric only the unchanged pair) and the baseline among them.
void set_steps(Evaluation& ev, bool radiometric) {
  ev.steps = radiometric ? exposure_study_steps() : std::vector<RadiometricChange>{RadiometricChange{}};
  const auto identity = std::find_if(ev.steps.begin(), ev.steps.end(),
                                     [](const RadiometricChange& c) { return c.kind == RadiometricKind::Identity; });
  ev.baseline = identity == ev.steps.end() ? 0 : static_cast<std::size_t>(identity - ev.steps.begin());
}

// Writes the files of --save, kept until the tables were printed.
void write_saved(const std::string& dir, const std::vector<std::pair<std::string, std::vector<std::uint8_t>>>& saved) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw RuntimeError("--save: cannot create the folder " + in_quotes(dir) + ": " + ec.message());
  PendingOutputs outputs;
  for (const auto& [path, bytes] : saved) outputs.add(path, bytes);
  outputs.commit();
}

}  // namespace

void EvalCommand::run() const {
  const Backend backend = run_flags_.parsed_backend();
  Evaluation ev;
  ev.backend = backend;
  ev.threshold = threshold_;
  ev.simd_target = backend == Backend::Reference ? "scalar" : "";
  // The methods: each preset of the list (every preset by default for the study), then the peers.
  const bool preset_given = command_->get_option("--preset")->count() > 0;
  for (const std::string& name :
       !preset_given && radiometric_ ? preset_names() : preset_list_of(parameters_.preset_name())) {
    const StereoParams params = resolve_preset(name);  // UsageError for an unknown preset
    check_parameters(params);
    ev.methods.push_back({name, false, params});
  }
  ev.preset_count = ev.methods.size();
  if (peers_)
    for (const Peer& p : make_peers(0, 16)) ev.methods.push_back({p.name, true, {}});

  if (!json_.empty()) check_output_path(json_, {}, "JSON report");
  std::error_code ec;
  if (!save_dir_.empty() && fs::exists(save_dir_, ec) && !fs::is_directory(save_dir_, ec))
    throw RuntimeError("--save " + in_quotes(save_dir_) + " is not a folder");
  // Every scene is read and checked before anything is matched.
  const std::vector<std::string> inputs = load_scenes(ev, data_);
  RunContext run;
  run.flags = &run_flags_;
  run.repeat = repeat_;
  // --min-disparity and --num-disparities, where given, replace the scenes' ranges (every preset holds them).
  if (parameters_.given("--min-disparity")) run.min_disparity = ev.methods[0].params.min_disparity;
  if (parameters_.given("--num-disparities")) run.num_disparities = ev.methods[0].params.num_disparities;
  for (const SceneData& s : ev.scenes)
    for (std::size_t m = 0; m < ev.preset_count; ++m)
      check_parameters(run.params(ev.methods[m], s), s.left.cols, s.left.rows);
  run.save = plan_saving(ev, save_dir_, json_, inputs);
  if (!json_.empty()) check_output_path(json_, inputs, "JSON report");
  set_steps(ev, radiometric_);

  if (run_flags_.threads > 0) cv::setNumThreads(run_flags_.threads);
  score_scenes(ev, run, quiet_);

  print_v2_table(ev);
  print_input(ev);
  print_v3_table(ev);
  print_sparsification_table(ev);
  Json study;
  if (radiometric_) study = report_study(ev);
  std::fflush(stdout);
  if (!save_dir_.empty()) write_saved(save_dir_, run.saved);
  if (!json_.empty())
    write_json_file(json_, json_report(ev, backend, run_flags_.threads, radiometric_ ? &study : nullptr,
                                       std::move(run.skipped)));
}

}  // namespace mctstereo::app
