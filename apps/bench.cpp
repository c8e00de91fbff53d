#include "bench.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/core/version.hpp>
#include <opencv2/imgproc.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>

#include "errors.hpp"
#include "io.hpp"
#include "output_files.hpp"
#include "statistics.hpp"

#ifndef MCTSTEREO_SOURCE_DIR
#define MCTSTEREO_SOURCE_DIR ""
#endif
#ifndef MCTSTEREO_VERSION
#define MCTSTEREO_VERSION "unknown"
#endif

namespace mctstereo::app {

namespace fs = std::filesystem;

namespace {

constexpr const char* kBenchFooter = R"(Each method matches the same gray frames (the Tsukuba pair, or --image-left/--image-right,
resized to each size): --warmup frames first, then at least --frames frames and until --min-time
seconds have passed. Times are wall-clock milliseconds per frame (median and 95th percentile);
fps = 1000 / median; "x BM" = fps / fps of OpenCV StereoBM (blockSize 9) on the same frames.
StereoSGBM: blockSize 5, MODE_SGBM_3WAY, P1 = 8*5*5, P2 = 32*5*5. OpenCV needs a multiple of 16
disparities: it searches --num-disparities rounded up to one.
)";

struct FrameSize {
  int width = 0, height = 0;
  std::string text() const { return std::to_string(width) + "x" + std::to_string(height); }
};

FrameSize parse_size(const std::string& text) {
  FrameSize s;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &s.width, &x, &s.height, &extra) != 3 || (x != 'x' && x != 'X') ||
      s.width < 1 || s.height < 1)
    throw UsageError("--sizes: '" + text + "' is not a size WIDTHxHEIGHT such as 640x480");
  return s;
}

struct Measurement {
  std::string method, kind;  // kind: "mctstereo" or "opencv"
  FrameSize size;
  int num_disparities = 0, threads = 0, frames = 0;
  double median_ms = 0, p95_ms = 0;
  double ratio_to_stereobm = 0;  // fps / fps of StereoBM at the same size
  double fps() const { return median_ms > 0 ? 1000.0 / median_ms : 0.0; }
};

// Runs `frame` warm-up times, then at least `frames` times and until `min_time_s` have passed.
std::vector<double> time_frames(const std::function<void()>& frame, int warmup, int frames, double min_time_s) {
  using Clock = std::chrono::steady_clock;
  for (int i = 0; i < warmup; ++i) frame();
  std::vector<double> ms;
  const auto start = Clock::now();
  // A ceiling keeps a tiny frame size from running for millions of frames.
  const std::size_t ceiling = static_cast<std::size_t>(std::max(frames, 10000));
  while (ms.size() < static_cast<std::size_t>(frames) ||
         (std::chrono::duration<double>(Clock::now() - start).count() < min_time_s && ms.size() < ceiling)) {
    const auto t0 = Clock::now();
    frame();
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  return ms;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  for (const char* key : {"model name", "Model", "Hardware", "cpu model"}) {
    in.clear();
    in.seekg(0);
    while (std::getline(in, line)) {
      if (line.rfind(key, 0) != 0) continue;
      const auto colon = line.find(':');
      if (colon == std::string::npos) continue;
      const auto start = line.find_first_not_of(" \t", colon + 1);
      if (start != std::string::npos) return line.substr(start);
    }
  }
  return "unknown";
}

long peak_resident_kib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;  // KiB on Linux
}

fs::path executable_folder() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}

// The bundled Tsukuba pair: --data (the tsukuba folder or a data folder holding it), else next
// to the executable, else in the source tree the program was built from.
std::pair<std::string, std::string> find_sample_pair(const std::string& data_flag) {
  std::vector<fs::path> folders;
  if (!data_flag.empty()) {
    folders = {fs::path(data_flag), fs::path(data_flag) / "tsukuba"};
  } else {
    const fs::path exe = executable_folder();
    if (!exe.empty())
      folders = {exe / "data/tsukuba", exe / "../data/tsukuba", exe / "../share/mctstereo/data/tsukuba"};
    if (*MCTSTEREO_SOURCE_DIR) folders.push_back(fs::path(MCTSTEREO_SOURCE_DIR) / "data/tsukuba");
  }
  std::error_code ec;
  for (const fs::path& f : folders)
    if (fs::is_regular_file(f / "imL.png", ec) && fs::is_regular_file(f / "imR.png", ec))
      return {(f / "imL.png").lexically_normal().string(), (f / "imR.png").lexically_normal().string()};
  if (!data_flag.empty())
    throw RuntimeError("--data " + in_quotes(data_flag) + ": no imL.png and imR.png there or in its tsukuba folder");
  throw RuntimeError("cannot find the sample pair data/tsukuba/imL.png, imR.png: give --data or --image-left and "
                     "--image-right");
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

BenchCommand::BenchCommand(CLI::App& parent)
    : command_(parent.add_subcommand("bench", "time the presets against OpenCV StereoBM and StereoSGBM")) {
  CLI::App& app = *command_;
  app.footer(kBenchFooter);
  app.add_option("--sizes", sizes_, "frame sizes WIDTHxHEIGHT, comma separated")->delimiter(',')->capture_default_str();
  app.add_option("--num-disparities", num_disparities_, "disparities searched, from 0")
      ->check(CLI::Range(1, 2048))
      ->capture_default_str();
  app.add_option("--presets", presets_, "presets to time, comma separated (default: all)")->delimiter(',');
  app.add_option("--frames", frames_, "frames timed per method and size (at least)")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  app.add_option("--warmup", warmup_, "untimed frames first")->check(CLI::Range(0, 1000000))->capture_default_str();
  app.add_option("--min-time", min_time_s_, "keep timing frames until this many seconds have passed")
      ->check(CLI::Range(0.0, 3600.0))
      ->capture_default_str();
  app.add_option("--json", json_, "also write the measurements and settings to this JSON file");
  app.add_option("--data", data_, "folder of the sample pair imL.png, imR.png (or a data folder with tsukuba/)");
  app.add_option("--image-left", image_left_, "left image to time on, instead of the sample pair");
  app.add_option("--image-right", image_right_, "right image to time on, instead of the sample pair");
  run_flags_.add_to(app);
}

void BenchCommand::run() const {
  const Backend backend = run_flags_.parsed_backend();
  std::vector<FrameSize> sizes;
  for (const std::string& s : sizes_) sizes.push_back(parse_size(s));
  if (sizes.empty()) throw UsageError("--sizes: no size given");
  std::vector<std::string> presets = presets_.empty() ? preset_names() : presets_;
  for (const std::string& name : presets) {
    try {
      (void)preset(name);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--presets: ") + e.what());
    }
  }
  if (image_left_.empty() != image_right_.empty())
    throw UsageError("--image-left and --image-right go together: give both or neither");
  if (!json_.empty()) check_output_path(json_, {}, "JSON report");

  const auto [left_path, right_path] =
      image_left_.empty() ? find_sample_pair(data_) : std::pair{image_left_, image_right_};
  const cv::Mat left_source = read_gray_image(left_path, "left image");
  const cv::Mat right_source = read_gray_image(right_path, "right image");
  if (left_source.size() != right_source.size())
    throw RuntimeError("left image " + in_quotes(left_path) + " and right image " + in_quotes(right_path) +
                       " differ in size");

  if (run_flags_.threads > 0) cv::setNumThreads(run_flags_.threads);
  const int opencv_disparities = (num_disparities_ + 15) / 16 * 16;
  std::vector<Measurement> measurements;
  std::string simd_target = backend == Backend::Reference ? "scalar" : "";
  int matcher_threads = 0;
  Json skipped = Json::array();

  std::printf("%-10s %5s %4s  %-18s %10s %10s %9s %7s %7s\n", "size", "disp", "thr", "method", "median_ms", "p95_ms",
              "fps", "x BM", "frames");
  std::fflush(stdout);
  for (const FrameSize& size : sizes) {
    cv::Mat left, right;
    cv::resize(left_source, left, cv::Size(size.width, size.height), 0, 0, cv::INTER_LINEAR);
    cv::resize(right_source, right, cv::Size(size.width, size.height), 0, 0, cv::INTER_LINEAR);
    std::vector<Measurement> rows;
    auto report = [&](Measurement m, const std::vector<double>& ms) {
      m.size = size;
      m.frames = static_cast<int>(ms.size());
      m.median_ms = median(ms);
      m.p95_ms = percentile(ms, 95.0);
      rows.push_back(m);
    };

    auto skip = [&](const std::string& method, const std::string& reason) {
      std::cerr << "mctstereo: note: skipping " << method << " at " << size.text() << ": " << reason << "\n";
      Json s = Json::object();
      s.set("method", method);
      s.set("size", size.text());
      s.set("reason", reason);
      skipped.push_back(std::move(s));
    };

    // OpenCV first: StereoBM is the yardstick of the ratios. StereoSGBM (4.6) throws when the
    // frame is as narrow as its range and crashes when narrower, and StereoBM finds nothing there:
    // such sizes skip OpenCV rather than end the benchmark.
    cv::Mat disparity;
    auto time_opencv = [&](const std::string& method, const cv::Ptr<cv::StereoMatcher>& matcher) {
      if (size.width <= opencv_disparities) {
        skip(method, "OpenCV needs a frame wider than its " + std::to_string(opencv_disparities) + " disparities");
        return;
      }
      try {
        report({method, "opencv", {}, opencv_disparities, cv::getNumThreads()},
               time_frames([&] { matcher->compute(left, right, disparity); }, warmup_, frames_, min_time_s_));
      } catch (const cv::Exception& e) {
        skip(method, "OpenCV: " + e.err);
      }
    };
    time_opencv("opencv-stereobm", cv::StereoBM::create(opencv_disparities, 9));
    time_opencv("opencv-stereosgbm", cv::StereoSGBM::create(0, opencv_disparities, 5, 8 * 5 * 5, 32 * 5 * 5, 0, 0, 0,
                                                            0, 0, cv::StereoSGBM::MODE_SGBM_3WAY));
    for (const std::string& name : presets) {
      StereoParams params = preset(name);
      params.min_disparity = 0;
      params.num_disparities = num_disparities_;
      const std::string problems = params.validate(size.width, size.height);
      if (!problems.empty()) {
        skip(name, problems.substr(0, problems.find('\n')));
        continue;
      }
      MatcherOptions options;
      options.threads = run_flags_.threads;
      Matcher matcher(size.width, size.height, params, backend, options);
      simd_target = matcher.simd_target();
      matcher_threads = matcher.threads();
      const ImageView l = image_view(left), r = image_view(right);
      report({name, "mctstereo", {}, num_disparities_, matcher.threads()},
             time_frames([&] { matcher.compute(l, r); }, warmup_, frames_, min_time_s_));
    }
    const bool have_bm = !rows.empty() && rows.front().method == "opencv-stereobm";
    for (Measurement& m : rows) {
      m.ratio_to_stereobm = have_bm ? m.fps() / rows.front().fps() : std::numeric_limits<double>::quiet_NaN();
      const std::string ratio = have_bm ? fixed(m.ratio_to_stereobm, 3) : "-";
      std::printf("%-10s %5d %4d  %-18s %10.3f %10.3f %9.1f %7s %7d\n", m.size.text().c_str(), m.num_disparities,
                  m.threads, m.method.c_str(), m.median_ms, m.p95_ms, m.fps(), ratio.c_str(), m.frames);
      measurements.push_back(m);
    }
    std::fflush(stdout);
  }

  // Memory: what this process reached, and what the matcher itself needs at the largest size.
  const FrameSize largest = *std::max_element(sizes.begin(), sizes.end(), [](const FrameSize& a, const FrameSize& b) {
    return static_cast<long>(a.width) * a.height < static_cast<long>(b.width) * b.height;
  });
  const long peak_kib = peak_resident_kib();
  Json estimates = Json::object();
  std::string estimate_text;
  for (const std::string& name : presets) {
    StereoParams params = preset(name);
    params.min_disparity = 0;
    params.num_disparities = num_disparities_;
    if (!params.validate(largest.width, largest.height).empty()) continue;
    MatcherOptions options;
    options.threads = run_flags_.threads;
    const std::size_t bytes = estimate_memory(params, largest.width, largest.height, options);
    estimates.set(name, bytes);
    estimate_text += (estimate_text.empty() ? "" : ", ") + name + " " + fixed(bytes / 1048576.0, 1);
  }
  std::printf("peak resident memory %s MiB; matcher memory at %s (estimate_memory, MiB): %s\n",
              fixed(peak_kib / 1024.0, 1).c_str(), largest.text().c_str(), estimate_text.c_str());
  const std::string cpu = cpu_model();
  std::printf("CPU %s, %ld cores online, SIMD %s, mctstereo %s, OpenCV %s\n", cpu.c_str(), sysconf(_SC_NPROCESSORS_ONLN),
              simd_target.c_str(), MCTSTEREO_VERSION, CV_VERSION);

  if (!json_.empty()) {
    Json settings = Json::object();
    settings.set("cpu_model", cpu);
    settings.set("cores_online", static_cast<long>(sysconf(_SC_NPROCESSORS_ONLN)));
    settings.set("simd_target", simd_target);
    settings.set("backend", to_string(backend));
    settings.set("threads_requested", run_flags_.threads);
    settings.set("threads", matcher_threads);
    settings.set("opencv_threads", cv::getNumThreads());
    settings.set("mctstereo_version", MCTSTEREO_VERSION);
    settings.set("opencv_version", CV_VERSION);
    settings.set("warmup_frames", warmup_);
    settings.set("min_frames", frames_);
    settings.set("min_time_s", min_time_s_);
    settings.set("left_image", left_path);
    settings.set("right_image", right_path);
    Json records = Json::array();
    for (const Measurement& m : measurements) {
      Json r = Json::object();
      r.set("method", m.method);
      r.set("kind", m.kind);
      r.set("width", m.size.width);
      r.set("height", m.size.height);
      r.set("num_disparities", m.num_disparities);
      r.set("threads", m.threads);
      r.set("frames", m.frames);
      r.set("median_ms", m.median_ms);
      r.set("p95_ms", m.p95_ms);
      r.set("fps", m.fps());
      r.set("ratio_to_stereobm", m.ratio_to_stereobm);  // null without a StereoBM time
      records.push_back(std::move(r));
    }
    Json memory = Json::object();
    memory.set("peak_resident_bytes", static_cast<long long>(peak_kib) * 1024);
    memory.set("estimate_size", largest.text());
    memory.set("estimate_memory_bytes", std::move(estimates));
    Json report = Json::object();
    report.set("settings", std::move(settings));
    report.set("records", std::move(records));
    report.set("memory", std::move(memory));
    report.set("skipped", std::move(skipped));
    write_json_file(json_, report);
  }
}

}  // namespace mctstereo::app
