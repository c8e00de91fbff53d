#include "eval.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>

#include "errors.hpp"
#include "eval_metrics.hpp"
#include "io.hpp"
#include "output_files.hpp"
#include "statistics.hpp"

namespace mctstereo::app {

namespace fs = std::filesystem;

namespace {

constexpr const char* kEvalFooter = R"(Scores (Middlebury v2): percent of bad pixels, |d - ground truth| > 1 px (--threshold), in
the nonocc, all and disc masks (value 255); pixels without a disparity count as bad. density is
the percent of pixels with a disparity; ms the matcher's frame time (median of --repeat frames
after one untimed frame). A scene folder holds a scene.txt (key=value: left, right, gt, gt_scale,
gt_invalid, max_disp, masks); each scene searches 0 .. max_disp unless --min-disparity or
--num-disparities say otherwise. Scenes without masks (masks=none) are skipped with a note.
)";

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

// One scene as scene.txt describes it.
struct Scene {
  fs::path folder;
  std::string name, set;
  std::map<std::string, std::string> keys;

  const std::string& key(const std::string& k) const {
    const auto it = keys.find(k);
    if (it == keys.end() || it->second.empty())
      throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + " has no '" + k + "=' line");
    return it->second;
  }
  double number(const std::string& k) const {
    const std::string& text = key(k);
    try {
      std::size_t used = 0;
      const double v = std::stod(text, &used);
      if (trim(text.substr(used)).empty() && std::isfinite(v)) return v;
    } catch (const std::exception&) {
    }
    throw RuntimeError("scene " + in_quotes(folder / "scene.txt") + ": " + k + "=" + text + " is not a number");
  }
  std::string file(const std::string& name_in_scene) const { return (folder / name_in_scene).string(); }
};

struct SceneResult {
  Scene scene;
  int width = 0, height = 0;
  StereoParams params;
  MiddleburyV2Score score;
  double ms = 0.0;
};

template <typename T>
MapView<const T> map_view(const cv::Mat& m) {
  return {m.ptr<const T>(0), m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step[0] / sizeof(T))};
}

cv::Mat read_mask(const Scene& scene, const std::string& name, const cv::Size& size) {
  const std::string path = scene.file(name);
  cv::Mat mask = read_gray_image(path, "mask of scene " + scene.name);
  if (mask.size() != size)
    throw RuntimeError("mask " + in_quotes(path) + " is " + std::to_string(mask.cols) + "x" + std::to_string(mask.rows) +
                       ", the scene's images " + std::to_string(size.width) + "x" + std::to_string(size.height));
  return mask;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

std::map<std::string, std::string> read_scene_file(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw RuntimeError("cannot read " + in_quotes(path));
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
    : command_(parent.add_subcommand("eval", "score the matcher on Middlebury v2 scenes (bad pixels > 1 px)")),
      parameters_(*command_) {
  CLI::App& app = *command_;
  app.footer(kEvalFooter);
  app.add_option("DATA", data_, "a scene folder, or a folder searched recursively for scene folders")->required();
  app.add_option("--json", json_, "also write the scores, averages and parameters to this JSON file");
  app.add_option("--threshold", threshold_, "a pixel is bad when |d - ground truth| exceeds this, pixels")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  app.add_option("--repeat", repeat_, "time N frames per scene (after one untimed frame) and report the median")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  run_flags_.add_to(app);
}

void EvalCommand::run() const {
  const StereoParams base = parameters_.resolve();
  const Backend backend = run_flags_.parsed_backend();
  if (!json_.empty()) check_output_path(json_, {}, "JSON report");

  const std::vector<fs::path> folders = find_scene_folders(data_);
  if (folders.empty())
    throw RuntimeError("no scene under " + in_quotes(data_) + ": a scene folder holds a scene.txt (see data/README.md)");

  std::vector<SceneResult> results;
  Json skipped = Json::array();
  std::string simd_target;
  int threads = 0;
  for (const fs::path& folder : folders) {
    Scene scene;
    scene.folder = folder;
    scene.keys = read_scene_file(folder / "scene.txt");
    scene.name = scene.keys.count("scene") ? scene.keys["scene"] : folder.filename().string();
    scene.set = scene.keys.count("set") ? scene.keys["set"] : "";

    std::vector<std::string> masks;
    std::istringstream mask_list(scene.keys.count("masks") ? scene.keys["masks"] : "none");
    for (std::string m; mask_list >> m;)
      if (m != "none") masks.push_back(m);
    if (masks.size() != 3) {
      std::cerr << "mctstereo: note: skipping scene " << scene.name << " (" << folder.string()
                << "): no nonocc, all and disc masks; the Middlebury v2 scores need them\n";
      Json s = Json::object();
      s.set("scene", scene.name);
      s.set("path", folder.string());
      s.set("reason", "no nonocc/all/disc masks");
      skipped.push_back(std::move(s));
      continue;
    }

    const cv::Mat left = read_input_image(scene.file(scene.key("left")), "left image of scene " + scene.name);
    const cv::Mat right = read_input_image(scene.file(scene.key("right")), "right image of scene " + scene.name);
    if (left.size() != right.size())
      throw RuntimeError("scene " + scene.name + ": left image is " + std::to_string(left.cols) + "x" +
                         std::to_string(left.rows) + ", right image " + std::to_string(right.cols) + "x" +
                         std::to_string(right.rows));
    const std::string gt_path = scene.file(scene.key("gt"));
    const cv::Mat gt_raw = read_gray_image(gt_path, "ground truth of scene " + scene.name);
    if (gt_raw.size() != left.size())
      throw RuntimeError("ground truth " + in_quotes(gt_path) + " is " + std::to_string(gt_raw.cols) + "x" +
                         std::to_string(gt_raw.rows) + ", the scene's images " + std::to_string(left.cols) + "x" +
                         std::to_string(left.rows));
    const double gt_scale = scene.number("gt_scale");
    if (!(gt_scale > 0)) throw RuntimeError("scene " + scene.name + ": gt_scale must be positive");
    const int gt_invalid = scene.keys.count("gt_invalid") ? static_cast<int>(scene.number("gt_invalid")) : 0;
    // Ground truth in pixels; NaN marks the pixels without one, which the metrics leave out.
    cv::Mat gt(gt_raw.size(), CV_32FC1);
    for (int y = 0; y < gt.rows; ++y)
      for (int x = 0; x < gt.cols; ++x) {
        const int v = gt_raw.at<std::uint8_t>(y, x);
        gt.at<float>(y, x) = v == gt_invalid ? std::numeric_limits<float>::quiet_NaN()
                                             : static_cast<float>(v / gt_scale);
      }
    const cv::Mat nonocc = read_mask(scene, masks[0], left.size());
    const cv::Mat all = read_mask(scene, masks[1], left.size());
    const cv::Mat disc = read_mask(scene, masks[2], left.size());

    StereoParams params = base;
    const int max_disp = static_cast<int>(std::ceil(scene.number("max_disp")));
    if (!parameters_.given("--min-disparity")) params.min_disparity = 0;
    if (!parameters_.given("--num-disparities")) params.num_disparities = max_disp - params.min_disparity + 1;
    check_parameters(params, left.cols, left.rows);

    MatcherOptions options;
    options.threads = run_flags_.threads;
    Matcher matcher(left.cols, left.rows, params, backend, options);
    // One untimed frame first: the first compute() also pays for page faults and thread start-up.
    std::vector<double> frame_ms;
    for (int frame = -1; frame < repeat_; ++frame) {
      matcher.compute(image_view(left), image_view(right));
      if (frame >= 0) frame_ms.push_back(matcher.timings().back().ms);
    }
    simd_target = matcher.simd_target();
    threads = matcher.threads();

    SceneResult r;
    r.scene = scene;
    r.width = left.cols;
    r.height = left.rows;
    r.params = params;
    r.score = score_middlebury_v2(matcher.disparity(), map_view<float>(gt), map_view<std::uint8_t>(nonocc),
                                  map_view<std::uint8_t>(all), map_view<std::uint8_t>(disc), threshold_);
    r.ms = median(frame_ms);
    results.push_back(std::move(r));
  }
  if (results.empty())
    throw RuntimeError("no scene with Middlebury v2 masks (nonocc, all, disc) under " + in_quotes(data_));

  double sum_nonocc = 0, sum_all = 0, sum_disc = 0, sum_density = 0, sum_ms = 0;
  std::printf("%-16s %8s %8s %8s %8s %9s\n", "scene", "nonocc", "all", "disc", "density", "ms");
  Json scenes = Json::array();
  for (const SceneResult& r : results) {
    const MiddleburyV2Score& s = r.score;
    std::printf("%-16s %8.2f %8.2f %8.2f %8.1f %9.1f\n", r.scene.name.c_str(), s.nonocc.percent(), s.all.percent(),
                s.disc.percent(), s.density_percent, r.ms);
    sum_nonocc += s.nonocc.percent();
    sum_all += s.all.percent();
    sum_disc += s.disc.percent();
    sum_density += s.density_percent;
    sum_ms += r.ms;
    Json j = Json::object();
    j.set("scene", r.scene.name);
    j.set("set", r.scene.set);
    j.set("path", r.scene.folder.string());
    j.set("width", r.width);
    j.set("height", r.height);
    j.set("min_disparity", r.params.min_disparity);
    j.set("num_disparities", r.params.num_disparities);
    j.set("nonocc", s.nonocc.percent());
    j.set("all", s.all.percent());
    j.set("disc", s.disc.percent());
    j.set("density", s.density_percent);
    j.set("ms", r.ms);
    Json pixels = Json::object();
    pixels.set("nonocc", s.nonocc.pixels);
    pixels.set("all", s.all.pixels);
    pixels.set("disc", s.disc.pixels);
    j.set("pixels", std::move(pixels));
    scenes.push_back(std::move(j));
  }
  const double n = static_cast<double>(results.size());
  const double avg_nonocc = sum_nonocc / n, avg_all = sum_all / n, avg_disc = sum_disc / n;
  // Middlebury's "average percent bad": the mean of all 3 x scenes numbers.
  const double average_percent_bad = (avg_nonocc + avg_all + avg_disc) / 3.0;
  std::printf("%-16s %8.2f %8.2f %8.2f %8.1f %9.1f\n", "average", avg_nonocc, avg_all, avg_disc, sum_density / n,
              sum_ms / n);
  std::printf("average percent bad (%zu numbers, > %s px): %.2f; preset %s, backend %s, SIMD %s, threads %d\n",
              3 * results.size(), fixed(threshold_, 2).c_str(), average_percent_bad,
              parameters_.preset_name().c_str(), std::string(to_string(backend)).c_str(), simd_target.c_str(),
              threads);

  if (!json_.empty()) {
    Json report = Json::object();
    report.set("preset", parameters_.preset_name());
    report.set("backend", to_string(backend));
    report.set("simd_target", simd_target);
    report.set("threads", threads);
    report.set("threshold", static_cast<double>(threshold_));
    // The scenes' own ranges replace these two fields unless they were given as flags.
    report.set("parameters", parameters_json(base));
    report.set("scenes", std::move(scenes));
    Json average = Json::object();
    average.set("nonocc", avg_nonocc);
    average.set("all", avg_all);
    average.set("disc", avg_disc);
    average.set("density", sum_density / n);
    average.set("ms", sum_ms / n);
    report.set("average", std::move(average));
    report.set("average_percent_bad", average_percent_bad);
    report.set("skipped", std::move(skipped));
    write_json_file(json_, report);
  }
}

}  // namespace mctstereo::app
