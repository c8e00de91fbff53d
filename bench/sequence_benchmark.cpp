// The temporal prior on sequences made from Middlebury scenes: each scene as a still camera (the
// pair with fresh sensor noise every frame) and as pans (a window 32 px narrower than the scene
// moving s px a frame, back to the start after 32 px, with noise), matched frame by frame with and
// without StereoParams::temporal. Per sequence: bad pixels of the left map against the ground
// truth (non-occluded, |d - truth| > 1 px or invalid), candidates per pixel at the finest level and
// the frame time (median), over every frame but the first.
//
//   mctstereo_sequence_benchmark [--presets balanced,quality] [--frames 30] [--pan-speeds 1,12]
//                                [--threads 2] [--json FILE] SCENE...
#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "eval.hpp"
#include "json.hpp"
#include "machine_info.hpp"
#include "mctstereo/matcher.hpp"
#include "mctstereo/metrics.hpp"
#include "mctstereo/version.hpp"

namespace {

using namespace mctstereo;

constexpr int kPanWidth = 32;  // the pans' window is this much narrower than the scene
constexpr double kNoiseSigma = 2.0;

// A sequence: still (pan_speed 0) or a pan of pan_speed px a frame.
struct Sequence {
  int pan_speed = 0;
  std::string name() const { return pan_speed == 0 ? "still" : "pan " + std::to_string(pan_speed) + " px"; }
};

// Frame f of a sequence: the scene's pair (a window of it for a pan) with Gaussian noise of its own.
struct Frame {
  cv::Mat left, right, truth, nonocc;
};

Frame make_frame(const app::ScenePair& s, const Sequence& q, int f) {
  const cv::Rect window = q.pan_speed > 0 ? cv::Rect(f * q.pan_speed % kPanWidth, 0, s.left.cols - kPanWidth, s.left.rows)
                                          : cv::Rect(0, 0, s.left.cols, s.left.rows);
  Frame out{s.left(window).clone(), s.right(window).clone(), s.ground_truth(window), s.nonocc(window)};
  cv::RNG rng(static_cast<std::uint64_t>(1000 + f));
  for (cv::Mat* view : {&out.left, &out.right}) {
    cv::Mat noise(view->size(), CV_MAKETYPE(CV_16S, view->channels()));
    rng.fill(noise, cv::RNG::NORMAL, 0.0, kNoiseSigma);
    cv::Mat wide;
    view->convertTo(wide, CV_16S);
    wide += noise;
    wide.convertTo(*view, view->type());  // saturates to 0..255
  }
  return out;
}

ImageView view_of(const cv::Mat& m) {
  return {m.data, m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step[0]),
          m.channels() == 3 ? PixelFormat::Bgr8 : PixelFormat::Gray8};
}

template <typename T>
MapView<const T> map_view(const cv::Mat& m) {
  return {m.ptr<const T>(0), m.cols, m.rows, static_cast<std::ptrdiff_t>(m.step[0] / sizeof(T))};
}

double percent_bad(const Frame& f, const Matcher& m) {
  return bad_pixels(m.disparity(), map_view<float>(f.truth), map_view<std::uint8_t>(f.nonocc)).percent();
}

struct Result {
  double bad = 0, candidates = 0, ms = 0;
  app::Json json() const {
    app::Json j = app::Json::object();
    j.set("bad_percent", bad);
    j.set("candidates", candidates);
    j.set("median_ms", ms);
    return j;
  }
};

Result run_sequence(const app::ScenePair& s, const StereoParams& p, const Sequence& q, int frames, int threads) {
  MatcherOptions options;
  options.threads = threads;
  const int w = q.pan_speed > 0 ? s.left.cols - kPanWidth : s.left.cols;
  Matcher m(w, s.left.rows, p, Backend::Cpu, options);
  Result r;
  std::vector<double> ms;
  for (int f = 0; f < frames; ++f) {
    const Frame frame = make_frame(s, q, f);
    m.compute(view_of(frame.left), view_of(frame.right));
    if (f == 0) continue;
    ms.push_back(m.timings().back().ms);
    r.bad += percent_bad(frame, m);
    r.candidates += m.level_work().front().candidates;
  }
  r.bad /= frames - 1;
  r.candidates /= frames - 1;
  std::nth_element(ms.begin(), ms.begin() + ms.size() / 2, ms.end());
  r.ms = ms[ms.size() / 2];
  return r;
}

app::Json settings_json(int threads, int frames, const std::string& command) {
  app::Json s = app::Json::object();
  s.set("cpu_model", app::cpu_model());
  s.set("cores_online", static_cast<long>(sysconf(_SC_NPROCESSORS_ONLN)));
  s.set("simd_target", Matcher(64, 32, preset("realtime")).simd_target());
  s.set("threads", threads);
  s.set("frames", frames);
  s.set("noise_sigma", kNoiseSigma);
  s.set("pan_window_narrower_by", kPanWidth);
  s.set("compiler", app::compiler_version());
  s.set("build_type", app::build_type());
  s.set("date", app::utc_date());
  s.set("mctstereo_version", std::string(version()));
  s.set("opencv_version", CV_VERSION);
  s.set("command_line", command);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("the temporal prior on still and panning sequences made from Middlebury scenes");
  std::vector<std::string> scenes, presets{"balanced", "quality"};
  std::vector<int> pan_speeds{1, 12};
  int frames = 30, threads = 2;
  std::string json_path;
  app.add_option("scenes", scenes, "scene folders (as eval reads them)")->required();
  app.add_option("--presets", presets, "presets")->delimiter(',');
  app.add_option("--frames", frames, "frames per sequence, [2, 1000]")->check(CLI::Range(2, 1000));
  app.add_option("--pan-speeds", pan_speeds, "pans: pixels per frame, each in [1, 31]")
      ->delimiter(',')
      ->check(CLI::Range(1, 31));
  app.add_option("--threads", threads, "threads of the cpu backend")->check(CLI::Range(1, 64));
  app.add_option("--json", json_path, "also write the settings and every row to this JSON file");
  CLI11_PARSE(app, argc, argv);
  std::string command;
  for (int i = 0; i < argc; ++i) command += (i > 0 ? " " : "") + std::string(argv[i]);
  std::vector<Sequence> sequences{{0}};
  for (int speed : pan_speeds) sequences.push_back({speed});
  try {
    for (const std::string& name : presets) (void)preset(name);  // an unknown name fails before any work
    app::Json rows = app::Json::array();
    std::printf("%-10s %-9s %-10s | %-17s | %-21s | %-17s\n", "scene", "preset", "sequence", "bad % (temporal)",
                "candidates (temporal)", "ms (temporal)");
    for (const std::string& folder : scenes) {
      const app::ScenePair s = app::read_scene_pair(folder);
      for (const std::string& name : presets) {
        StereoParams p = preset(name);
        p.min_disparity = s.min_disparity;
        p.num_disparities = s.num_disparities;
        StereoParams t = p;
        t.temporal = true;
        for (const Sequence& q : sequences) {
          const Result alone = run_sequence(s, p, q, frames, threads);
          const Result with = run_sequence(s, t, q, frames, threads);
          std::printf("%-10s %-9s %-10s | %7.2f (%7.2f) | %9.2f (%9.2f) | %7.2f (%7.2f)\n", s.name.c_str(),
                      name.c_str(), q.name().c_str(), alone.bad, with.bad, alone.candidates, with.candidates,
                      alone.ms, with.ms);
          std::fflush(stdout);
          app::Json row = app::Json::object();
          row.set("scene", s.name);
          row.set("preset", name);
          row.set("sequence", q.name());
          row.set("pan_speed", q.pan_speed);
          row.set("alone", alone.json());
          row.set("temporal", with.json());
          rows.push_back(std::move(row));
        }
      }
    }
    if (!json_path.empty()) {
      app::Json doc = app::Json::object();
      doc.set("settings", settings_json(threads, frames, command));
      doc.set("rows", std::move(rows));
      app::write_json_file(json_path, doc);
    }
  } catch (const std::exception& e) {
    std::cerr << "mctstereo_sequence_benchmark: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
