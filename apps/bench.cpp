// `mctstereo bench`.
//
// Every combination of --sizes x --num-disparities x --threads is one group: OpenCV StereoBM and
// StereoSGBM (apps/peers.hpp, the configuration `eval` compares with) and then every preset on each
// --backend, all on the same gray frames. The reference backend is single-threaded and the opencl
// backend runs on its device, so they are timed once per (size, disparities), in the group of the
// first --threads value. --backend auto is resolved first: it times whichever backend it picks. After the timing, one
// fresh child process per (size, disparities, preset) measures the matcher's peak resident memory.
//
// The JSON report (--json), an object:
//   "settings": {
//     "cpu_model", "cpu_mhz" (/proc/cpuinfo's clock, 0 where none), "cores_online", "load_threads" (--load), "gomp_spincount" and
//     "omp_wait_policy" (the environment's, "" when unset), "simd_target" (of the cpu backend; "scalar" when only the
//     reference backend ran), "openmp_max_threads" (threads of --threads 0), "compiler",
//     "build_type", "date" (UTC, ISO 8601), "mctstereo_version", "opencv_version",
//     "backend", "threads_requested", "threads", "opencv_threads": the first --backend and
//       --threads values and the threads they gave (one-value runs read as they always did),
//     "backends": [..] (auto resolved), "thread_settings": [..] (0 = all cores), "num_disparities": [..],
//     "opencl_device": "NAME (PLATFORM)" when the opencl backend ran, else absent,
//     "sizes": ["WxH", ..], "presets": [..],
//     "warmup_frames", "min_frames", "min_time_s": the flags, before the per-size scaling,
//     "left_image", "right_image", "fit" ("stretch" or "tile": --fit), "memory_only" (--memory-only:
//     no timing records), "adapt_threads" (false with --fixed-threads) }
//   "records": one per (method, size, disparities, threads, backend) timed: {
//     "method" (a preset, "opencv-stereobm" or "opencv-stereosgbm"), "kind" ("mctstereo" or
//     "opencv"), "width", "height", "num_disparities" (OpenCV: rounded up to a multiple of 16),
//     "threads" (used), "frames" (timed), "median_ms", "p95_ms", "fps" (1000 / median_ms),
//     "mean_ms" (the timed frames' total time over their count: 1000 / mean_ms is the frame rate
//     sustained, which on a loaded CPU counts the frames that the OS preempted, as the median does not),
//     "cpu_cores" (CPU seconds of this process per wall-clock second over the timed frames: the
//     cores the method was given, waiting threads included; below "threads" under --load),
//     "backend" (mctstereo only), "threads_requested" (the --threads value of the group),
//     "warmup_frames", "stage_median_ms" (mctstereo only: the median over the timed frames of each
//     entry of Matcher::timings(); reference and cpu: {"gray", "pyramid", "census", "match",
//     "refine", "wmedian" (the colour-weighted median), "output", "frame"}; opencl: {"upload", "gray", "pyramid", "census", "match",
//     "median", "lr_check", "speckle", "fill", "upscale", "output", "download", "frame"}, the
//     kernels' device times from profiling events and the host's times of the rest),
//     "level_work" (reference and cpu: per level, finest first, {"width", "height", "views",
//     "candidates"}: Matcher::level_work() of the last frame), "frames_alone" (mctstereo only:
//     Matcher::frames_alone(), warm-up frames included),
//     "ratio_to_stereobm" (fps / fps of StereoBM in the same group; null without one), last }
//   "memory": {
//     "peak_resident_bytes": this process's peak resident memory (VmHWM), every size included,
//     "estimate_size": the largest size, "estimate_num_disparities": the first --num-disparities,
//     "estimate_memory_bytes": {preset: estimate_memory at that size and range},
//     "records": one per (size, disparities, preset): { "method", "width", "height",
//       "num_disparities", "backend", "threads", "estimate_memory_bytes" (estimate_memory with the
//       matcher's thread count), "peak_resident_bytes" (the child's peak resident memory over its
//       resident memory just before it built the matcher, one frame matched), "baseline_resident_bytes",
//       "peak_measure" ("reset": the peak was reset to the resident memory at the baseline through
//       /proc/self/clear_refs; "difference": the kernel cannot reset it, so this is the rise of
//       the peak, which understates when the process had been higher before) } }
//   "skipped": [{"method", "size", "num_disparities", "reason"}]: what could not run, and why.
#include "bench.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/core/version.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include "cpu_load.hpp"
#include "errors.hpp"
#include "io.hpp"
#include "json.hpp"
#include "machine_info.hpp"
#include "options.hpp"
#include "output_files.hpp"
#include "pair_method.hpp"
#include "peers.hpp"
#include "statistics.hpp"

#ifndef MCTSTEREO_SOURCE_DIR
#define MCTSTEREO_SOURCE_DIR ""
#endif
#ifndef MCTSTEREO_VERSION
#define MCTSTEREO_VERSION "unknown"
#endif

extern char** environ;

namespace mctstereo::app {

namespace fs = std::filesystem;

namespace {

constexpr const char* kBenchFooter =
    R"(Each method matches the same gray frames (the Tsukuba pair, or --image-left/--image-right,
resized to each size, or with --fit tile repeated at its own size to fill it, so that disparities
and texture stay those of the pair at every size): --warmup frames first, then at least --frames frames and until --min-time
seconds have passed. Above 1280x720 both counts shrink with the pixel count (at least 5 timed
frames and 1 warm-up); the reference backend, slow, scales so from 320x240 on (at least 1 frame
each) and is timed once per size and range, with the first --threads value. A preset on several
threads that adapts them (no --fixed-threads) warms up at least 6 frames (with --warmup above 0):
its first 3 frames and its first trial of one thread, which are not its way.
Times are wall-clock milliseconds per frame (median and 95th percentile); fps = 1000 / median;
"x BM" = fps / fps of OpenCV StereoBM (blockSize 9) with the same size, range and threads.
mean_ms = the timed frames' total time over their count (1000 / mean_ms: the frame rate
sustained; under --load it counts the preempted frames that the median passes over);
cores = CPU time of this process per second of the timed frames, waiting threads included: what
the method was given (about its threads on an idle machine, less with --load).
StereoSGBM: blockSize 5, MODE_SGBM_3WAY, P1 = 8*5*5, P2 = 32*5*5. OpenCV needs a multiple of 16
disparities: it searches --num-disparities rounded up to one. Stage times are the medians of the
matcher's own per-stage times (frame = the whole call).
The opencl backend (--backend opencl, on --device) is timed once per size and range; its stage times
are the kernels' device times (profiling events) with the host's upload, download and speckle times.
Memory: a fresh process per size, range and preset builds the matcher (cpu backend unless only
reference is timed), matches one frame, and reports its peak resident memory over what it held just
before, next to estimate_memory().
--load N keeps N threads of another process busy (integer arithmetic) while every method is timed,
as on a robot or AR device whose cores run other work too.
--sizes thesis = 320x240,640x480,1024x768,1280x720,2048x1536,3840x2160.
)";

const std::vector<std::string> kThesisSizes = {"320x240", "640x480", "1024x768", "1280x720", "2048x1536", "3840x2160"};

struct FrameSize {
  int width = 0, height = 0;
  long pixels() const { return static_cast<long>(width) * height; }
  std::string text() const { return std::to_string(width) + "x" + std::to_string(height); }
  bool operator==(const FrameSize&) const = default;
};

FrameSize parse_size(const std::string& text) {
  FrameSize s;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &s.width, &x, &s.height, &extra) != 3 || (x != 'x' && x != 'X') ||
      s.width < 1 || s.height < 1)
    throw UsageError("--sizes: '" + text + "' is not a size WIDTHxHEIGHT such as 640x480 (or the list 'thesis')");
  return s;
}

std::vector<FrameSize> parse_sizes(const std::vector<std::string>& items) {
  std::vector<FrameSize> sizes;
  for (const std::string& item : items) {
    if (item == "thesis") {
      for (const std::string& s : kThesisSizes) sizes.push_back(parse_size(s));
    } else {
      sizes.push_back(parse_size(item));
    }
  }
  if (sizes.empty()) throw UsageError("--sizes: no size given");
  for (std::size_t i = 0; i < sizes.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (sizes[i] == sizes[j]) throw UsageError("--sizes: " + sizes[i].text() + " is given twice");
  return sizes;
}

// The whole numbers of a comma-separated flag, each in [lo, hi] and none twice.
std::vector<int> parse_counts(const std::string& flag, const std::vector<std::string>& items, int lo, int hi) {
  std::vector<int> values;
  for (const std::string& item : items) {
    int v = 0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
    if (item.empty() || ec != std::errc() || end != item.data() + item.size() || v < lo || v > hi)
      throw UsageError(flag + ": '" + item + "' is not a whole number from " + std::to_string(lo) + " to " +
                       std::to_string(hi));
    if (std::find(values.begin(), values.end(), v) != values.end())
      throw UsageError(flag + ": " + item + " is given twice");
    values.push_back(v);
  }
  if (values.empty()) throw UsageError(flag + ": no value given");
  return values;
}

std::vector<Backend> parse_backends(const std::vector<std::string>& items) {
  std::vector<Backend> backends;
  for (const std::string& item : items) {
    Backend b;
    try {
      b = parse_backend(item);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--backend: ") + e.what());
    }
    if (std::find(backends.begin(), backends.end(), b) != backends.end())
      throw UsageError("--backend: " + item + " is given twice");
    backends.push_back(b);
  }
  if (backends.empty()) throw UsageError("--backend: no backend given");
  return backends;
}

StereoParams bench_params(const std::string& preset_name, int num_disparities) {
  StereoParams params = preset(preset_name);
  params.min_disparity = 0;
  params.num_disparities = num_disparities;
  return params;
}

// A matcher of `backend`; for opencl, a RuntimeError naming the flags when its device cannot be
// had (none installed, --device names none, a kernel fails to build, too little memory).
Matcher open_backend(Backend backend, const std::string& device, const FrameSize& size, const StereoParams& params,
                     const MatcherOptions& options) {
  try {
    return Matcher(size.width, size.height, params, backend, options);
  } catch (const std::invalid_argument& e) {
    if (backend == Backend::OpenCL && !have_opencl()) throw UsageError(std::string("--backend opencl: ") + e.what());
    throw;
  } catch (const std::runtime_error& e) {
    throw RuntimeError((device.empty() ? "--backend " + std::string(to_string(backend)) : "--device " + device) +
                       ": " + e.what());
  }
}

// The same on a tiny frame: whether the backend can run here, and which one auto picks.
Matcher open_backend(Backend backend, const std::string& device) {
  StereoParams tiny;
  tiny.pyramid_levels = 1;
  tiny.num_disparities = 8;
  MatcherOptions options;
  options.device = device;
  return open_backend(backend, device, FrameSize{64, 32}, tiny, options);
}

struct Measurement {
  std::string method, kind;  // kind: "mctstereo" or "opencv"
  std::string backend;       // mctstereo only
  FrameSize size;
  int num_disparities = 0, threads_requested = 0, threads = 0, warmup = 0, frames = 0;
  double median_ms = 0, p95_ms = 0;
  double mean_ms = 0;    // the timed frames' total over their count: the frame rate the method sustains
  double cpu_cores = 0;  // TimedFrames::cpu_cores
  double ratio_to_stereobm = std::numeric_limits<double>::quiet_NaN();  // NaN: no StereoBM in the group
  std::vector<StageTime> stage_median_ms;                               // mctstereo only
  std::vector<LevelWork> work;  // host backends: the candidates the matching examined per level
  long frames_run = 0, frames_alone = 0;  // cpu backend: frames computed, and of those run on one thread
  double fps() const { return median_ms > 0 ? 1000.0 / median_ms : 0.0; }
};

struct MemoryRecord {
  std::string method, backend;
  FrameSize size;
  int num_disparities = 0, threads = 0;
  std::size_t estimate_bytes = 0;
  long long peak_bytes = 0, baseline_bytes = 0;
  std::string peak_measure;
};

struct FramePlan {
  int warmup = 0, frames = 0;
};

// Large frames take long enough that fewer of them give a stable median: above `full_pixels`
// both counts shrink in proportion to the pixel count.
FramePlan frame_plan(const FrameSize& size, bool reference_backend, int warmup, int frames) {
  const long full_pixels = reference_backend ? 320L * 240 : 1280L * 720;
  if (size.pixels() <= full_pixels) return {warmup, frames};
  const double scale = static_cast<double>(full_pixels) / static_cast<double>(size.pixels());
  const int least_frames = std::min(frames, reference_backend ? 1 : 5);
  return {std::max(std::min(warmup, 1), static_cast<int>(std::ceil(warmup * scale))),
          std::max(least_frames, static_cast<int>(std::ceil(frames * scale)))};
}

// The frame times of a method, and the processor time its process got meanwhile.
struct TimedFrames {
  std::vector<double> ms;
  // CPU seconds of this process (every thread, waiting ones included) per wall-clock second over
  // the timed frames: near the thread count on an idle machine, less where other processes share
  // the cores (--load), so that a loaded run shows what each method was given, not only its times.
  double cpu_cores = 0;
};

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// Runs `frame` plan.warmup times, then at least plan.frames times and until `min_time_s` have
// passed, calling `after_timed` after each timed frame (outside its time).
TimedFrames time_frames(const std::function<void()>& frame, const std::function<void()>& after_timed,
                        const FramePlan& plan, double min_time_s) {
  using Clock = std::chrono::steady_clock;
  for (int i = 0; i < plan.warmup; ++i) frame();
  TimedFrames timed;
  std::vector<double>& ms = timed.ms;
  const auto start = Clock::now();
  const double cpu_start = process_cpu_seconds();
  // A ceiling keeps a tiny frame size from running for millions of frames.
  const std::size_t ceiling = static_cast<std::size_t>(std::max(plan.frames, 10000));
  while (ms.size() < static_cast<std::size_t>(plan.frames) ||
         (std::chrono::duration<double>(Clock::now() - start).count() < min_time_s && ms.size() < ceiling)) {
    const auto t0 = Clock::now();
    frame();
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    if (after_timed) after_timed();
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  timed.cpu_cores = wall_s > 0 ? (process_cpu_seconds() - cpu_start) / wall_s : 0.0;
  return timed;
}

struct Settings {
  std::string cpu = cpu_model();
  long cores_online = sysconf(_SC_NPROCESSORS_ONLN);
  std::string simd_target = "unknown";
  int openmp_max_threads = 0;
};

// The SIMD target and the OpenMP default come from the library: ask a tiny matcher.
Settings probe_settings() {
  Settings s;
  try {
    StereoParams tiny;
    tiny.pyramid_levels = 1;
    tiny.num_disparities = 8;
    const Matcher probe(64, 32, tiny, Backend::Cpu);
    s.simd_target = probe.simd_target();
    s.openmp_max_threads = probe.threads();
  } catch (const std::invalid_argument&) {
    // Left "unknown": the settings block is informative, never a reason to stop.
  }
  return s;
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
  throw RuntimeError(
      "cannot find the sample pair data/tsukuba/imL.png, imR.png: give --data or --image-left and "
      "--image-right");
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string mib(double bytes) { return fixed(bytes / 1048576.0, 1); }

// "[k/n] what" on stderr: one line each, or one line rewritten in place on a terminal (cleared
// before anything else is printed, so the tables on stdout stay whole).
class Progress {
 public:
  explicit Progress(int total) : total_(total), terminal_(isatty(STDERR_FILENO) == 1) {}
  void step(const std::string& what) {
    ++done_;
    const std::string line = "mctstereo: [" + std::to_string(done_) + "/" + std::to_string(total_) + "] " + what;
    if (terminal_) {
      std::cerr << "\r\033[K" << line << std::flush;
      showing_ = true;
    } else {
      std::cerr << line << "\n" << std::flush;
    }
  }
  void clear() {
    if (!showing_) return;
    std::cerr << "\r\033[K" << std::flush;
    showing_ = false;
  }

 private:
  int total_, done_ = 0;
  bool terminal_, showing_ = false;
};

// --- Memory probe -------------------------------------------------------------------------------
// /proc/self/status's peak (VmHWM) covers the whole life of a process, so a process that has
// already matched larger frames cannot tell what one matcher needs. Each probe is this program
// again ("bench --memory-probe WxH:D:PRESET:BACKEND:THREADS"), fresh: it makes its frames, resets
// the peak to its present resident memory, builds the matcher, matches one frame, and prints
// "memory-probe BASELINE_KIB PEAK_KIB reset|difference" on stdout.

std::string probe_spec(const FrameSize& size, int num_disparities, const std::string& preset_name, Backend backend,
                       int threads) {
  return size.text() + ":" + std::to_string(num_disparities) + ":" + preset_name + ":" +
         std::string(to_string(backend)) + ":" + std::to_string(threads);
}

void run_memory_probe(const std::string& spec) {
  std::vector<std::string> parts;
  std::stringstream in(spec);
  for (std::string part; std::getline(in, part, ':');) parts.push_back(part);
  if (parts.size() != 5) throw UsageError("--memory-probe: '" + spec + "' is not WxH:D:PRESET:BACKEND:THREADS");
  const FrameSize size = parse_size(parts[0]);
  const int num_disparities = parse_counts("--memory-probe", {parts[1]}, 1, 2048).front();
  const Backend backend = parse_backends({parts[3]}).front();
  const int threads = parse_counts("--memory-probe", {parts[4]}, 0, 4096).front();
  StereoParams params;
  try {
    params = bench_params(parts[2], num_disparities);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--memory-probe: ") + e.what());
  }

  // A textured pair whose right view is the left one shifted by a quarter of the range: memory
  // does not depend on the content (the matcher allocates everything up front), but the frame is
  // a realistic one.
  const std::size_t w = static_cast<std::size_t>(size.width), h = static_cast<std::size_t>(size.height);
  std::vector<std::uint8_t> left(w * h), right(w * h);
  const std::size_t shift = static_cast<std::size_t>(num_disparities / 4);
  for (std::size_t y = 0; y < h; ++y)
    for (std::size_t x = 0; x < w; ++x) {
      const std::uint32_t hash = static_cast<std::uint32_t>((x * 73856093u) ^ (y * 19349663u)) * 2654435761u;
      left[y * w + x] = static_cast<std::uint8_t>(hash >> 24);
    }
  for (std::size_t y = 0; y < h; ++y)
    for (std::size_t x = 0; x < w; ++x) right[y * w + x] = left[y * w + std::min(w - 1, x + shift)];
  const ImageView l{left.data(), size.width, size.height, size.width, PixelFormat::Gray8};
  const ImageView r{right.data(), size.width, size.height, size.width, PixelFormat::Gray8};

  bool reset = false;
  {
    std::ofstream clear("/proc/self/clear_refs");
    clear << "5" << std::flush;  // 5: reset the peak resident memory to the present one (Linux 4.0+)
    reset = clear.good();
  }
  const long baseline_kib = status_kib(reset ? "VmRSS" : "VmHWM");
  MatcherOptions options;
  options.threads = threads;
  long peak_kib = -1;
  {
    Matcher matcher(size.width, size.height, params, backend, options);
    matcher.compute(l, r);
    peak_kib = status_kib("VmHWM");
  }
  if (baseline_kib < 0 || peak_kib < 0) throw RuntimeError("/proc/self/status holds no VmRSS and VmHWM lines");
  std::printf("memory-probe %ld %ld %s\n", baseline_kib, peak_kib, reset ? "reset" : "difference");
}

struct ProbeResult {
  long baseline_kib = -1, peak_kib = -1;
  std::string measure;
  std::string error;  // non-empty when the probe failed
};

ProbeResult spawn_memory_probe(const std::string& spec) {
  ProbeResult result;
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) return {-1, -1, "", "cannot make a pipe"};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  std::string args[] = {"mctstereo", "bench", "--memory-probe", spec};
  char* argv[] = {args[0].data(), args[1].data(), args[2].data(), args[3].data(), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, "/proc/self/exe", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  std::string out;
  if (spawned == 0) {
    char buf[256];
    for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) != 0;) {
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) break;
      out.append(buf, static_cast<std::size_t>(n));
    }
  }
  close(fds[0]);
  if (spawned != 0) return {-1, -1, "", "cannot start /proc/self/exe: " + std::string(std::strerror(spawned))};
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return {-1, -1, "",
            WIFEXITED(status) ? "the probe exited with status " + std::to_string(WEXITSTATUS(status))
                              : "the probe ended by signal " + std::to_string(WTERMSIG(status))};
  char measure[16] = {};
  if (std::sscanf(out.c_str(), "memory-probe %ld %ld %15s", &result.baseline_kib, &result.peak_kib, measure) != 3)
    return {-1, -1, "", "the probe printed no result"};
  result.measure = measure;
  return result;
}

Json stage_json(const std::vector<StageTime>& stages) {
  Json j = Json::object();
  for (const StageTime& s : stages) j.set(s.stage, s.ms);
  return j;
}


// --- The units of a run -------------------------------------------------------------------------

// What a run times and how, from the flags and the machine.
struct RunSetup {
  std::vector<FrameSize> sizes;
  std::vector<int> disparity_counts, thread_settings;
  std::vector<Backend> backends;  // auto resolved
  std::vector<std::string> presets;
  std::string device, opencl_device;  // --device; the OpenCL device's name when the opencl backend runs
  std::string left_path, right_path;
  Settings settings;
  std::string simd_target;  // of the cpu backend; "scalar" when only the reference backend runs
  int warmup = 0, frames = 0, load = 0, first_opencv_threads = 0;
  double min_time_s = 0.0;
  bool tile = false;  // --fit tile: the pair repeated at its own size, not resized
  bool memory_only = false;  // --memory-only: the memory table alone
  bool fixed_threads = false;  // --fixed-threads: MatcherOptions::adapt_threads = false

  bool has(Backend b) const { return std::find(backends.begin(), backends.end(), b) != backends.end(); }
};

// Resolves --backend auto to what it picks (once in the list) and opens the OpenCL device before
// any timing, so that a missing one costs nothing. Returns the OpenCL device's name, "" when none.
std::string resolve_backends(std::vector<Backend>& backends, const std::string& device) {
  std::string opencl_device;
  for (std::size_t i = 0; i < backends.size(); ++i) {
    if (backends[i] != Backend::Auto && backends[i] != Backend::OpenCL) continue;
    const Matcher probe = open_backend(backends[i], device);
    if (backends[i] == Backend::Auto) {
      if (!probe.notice().empty()) std::cerr << "mctstereo: note: --backend auto: " << probe.notice() << "\n";
      if (std::find(backends.begin(), backends.end(), probe.backend()) != backends.end()) {
        backends.erase(backends.begin() + static_cast<std::ptrdiff_t>(i--));
        continue;
      }
      backends[i] = probe.backend();
    }
    if (probe.backend() == Backend::OpenCL) opencl_device = probe.device_name();
  }
  return opencl_device;
}

// The lines above the tables: the machine, SIMD and threads, the OpenCL device, versions, waiting, load, date.
void print_header(const RunSetup& setup) {
  const auto join = [](const auto& items, auto text) {
    std::string s;
    for (const auto& item : items) {
      if (!s.empty()) s += ',';
      s += text(item);
    }
    return s;
  };
  const std::string backends_text = join(setup.backends, [](Backend b) { return std::string(to_string(b)); });
  const std::string threads_text = join(setup.thread_settings, [](int t) { return std::to_string(t); });
  std::printf("CPU       %s, %ld cores online\n", setup.settings.cpu.c_str(), setup.settings.cores_online);
  std::printf("SIMD      %s; OpenMP %d threads by default; timed with --threads %s, --backend %s\n",
              setup.simd_target.c_str(), setup.settings.openmp_max_threads, threads_text.c_str(), backends_text.c_str());
  if (!setup.opencl_device.empty()) std::printf("OpenCL    %s\n", setup.opencl_device.c_str());
  std::printf("versions  mctstereo %s, OpenCV %s, %s, build %s\n", MCTSTEREO_VERSION, CV_VERSION,
              compiler_version().c_str(), build_type().c_str());
  const char* spin_env = std::getenv("GOMP_SPINCOUNT");
  const char* policy_env = std::getenv("OMP_WAIT_POLICY");
  std::printf("waiting   OpenMP threads wait with GOMP_SPINCOUNT=%s, OMP_WAIT_POLICY=%s\n", spin_env ? spin_env : "(unset)",
              policy_env ? policy_env : "(unset)");
  if (setup.tile) std::printf("frames    the pair repeated at its own size to fill each size (--fit tile)\n");
  if (setup.load > 0) std::printf("load      %d busy threads in another process during the timing\n", setup.load);
  std::printf("threads   %s\n", setup.fixed_threads
                                   ? "every frame on all threads (--fixed-threads)"
                                   : "each frame on all threads or on one, whichever the matcher's recent frames "
                                     "found faster (adapt_threads; --fixed-threads: all)");
  std::printf("date      %s\n\n", utc_date().c_str());
}

// Progress steps: per (size, range) the peers and cpu presets per thread setting, the reference
// and opencl presets once, and one memory probe per preset.
int progress_steps(const RunSetup& setup) {
  const int presets = static_cast<int>(setup.presets.size());
  return static_cast<int>(setup.sizes.size() * setup.disparity_counts.size()) *
         (static_cast<int>(setup.thread_settings.size()) * (2 + (setup.has(Backend::Cpu) ? presets : 0)) +
          (setup.has(Backend::Reference) ? presets : 0) + (setup.opencl_device.empty() ? 0 : presets) + presets);
}

// What cannot run (a preset invalid at a size, OpenCV too narrow a frame): noted once per
// (method, size, range), though it comes up for every thread setting and backend.
class SkipNotes {
 public:
  explicit SkipNotes(Progress& progress) : progress_(progress) {}
  void note(const std::string& method, const FrameSize& size, int num_disparities, const std::string& reason) {
    if (!notes_.insert(method + " " + size.text() + " " + std::to_string(num_disparities)).second) return;
    progress_.clear();
    std::cerr << "mctstereo: note: skipping " << method << " at " << size.text() << " with " << num_disparities
              << " disparities: " << reason << "\n";
    Json s = Json::object();
    s.set("method", method);
    s.set("size", size.text());
    s.set("num_disparities", num_disparities);
    s.set("reason", reason);
    skipped_.push_back(std::move(s));
  }
  const Json& skipped() const { return skipped_; }

 private:
  Progress& progress_;
  Json skipped_ = Json::array();
  std::set<std::string> notes_;
};

// The first problem validate() finds with a preset at a size, "" when it suits.
std::string preset_problem(const std::string& name, const FrameSize& size, int num_disparities) {
  const std::string problems = bench_params(name, num_disparities).validate(size.width, size.height);
  return problems.substr(0, problems.find('\n'));
}

// The timing table as it fills: its rows, the progress line and the notes of what was skipped.
struct Timing {
  const RunSetup& setup;
  Progress& progress;
  SkipNotes& skips;
  std::vector<Measurement> measurements;
};

// One group of the table: a size, a range and a --threads value. StereoBM, timed first, is the
// yardstick of the ratios.
struct Group {
  FrameSize size;
  int num_disparities = 0, threads_requested = 0;
  std::string label;  // "640x480, 64 disparities, --threads 2: "
  double stereobm_fps = std::numeric_limits<double>::quiet_NaN();
};

void print_row(const Measurement& m) {
  const std::string ratio = std::isnan(m.ratio_to_stereobm) ? "-" : fixed(m.ratio_to_stereobm, 3);
  std::printf("%-10s %5d %4d  %-18s %-9s %10.3f %10.3f %9.1f %7s %7d %10.3f %6.2f\n", m.size.text().c_str(),
              m.num_disparities, m.threads, m.method.c_str(), m.backend.empty() ? "-" : m.backend.c_str(), m.median_ms,
              m.p95_ms, m.fps(), ratio.c_str(), m.frames, m.mean_ms, m.cpu_cores);
  std::fflush(stdout);
}

// Completes a measurement with its timed frames (in its group), prints and keeps it.
void record(Timing& t, Group& g, Measurement m, const TimedFrames& timed) {
  const std::vector<double>& ms = timed.ms;
  m.size = g.size;
  m.cpu_cores = timed.cpu_cores;
  m.threads_requested = g.threads_requested;
  m.frames = static_cast<int>(ms.size());
  m.median_ms = median(ms);
  m.p95_ms = percentile(ms, 95.0);
  m.mean_ms = std::accumulate(ms.begin(), ms.end(), 0.0) / static_cast<double>(ms.size());
  if (m.method == "opencv-stereobm") g.stereobm_fps = m.fps();
  m.ratio_to_stereobm = m.fps() / g.stereobm_fps;  // NaN without StereoBM
  t.progress.clear();
  print_row(m);
  t.measurements.push_back(std::move(m));
}

// Times OpenCV's matchers (the frames are gray: PairViews' gray views are the same images).
void time_peers(Timing& t, Group& g, const std::vector<Peer>& peers, const PairViews& views) {
  const FramePlan plan = frame_plan(g.size, false, t.setup.warmup, t.setup.frames);
  for (const Peer& peer : peers) {
    t.progress.step(g.label + peer.name);
    PeerMethod method(peer, 0, g.num_disparities);
    if (const std::string reason = peer_unsupported_reason(peer, g.size.width); !reason.empty()) {
      t.skips.note(peer.name, g.size, method.num_disparities, reason);
      continue;
    }
    try {
      Measurement m;
      m.method = peer.name;
      m.kind = "opencv";
      m.num_disparities = method.num_disparities;
      m.threads = cv::getNumThreads();
      m.warmup = plan.warmup;
      record(t, g, m, time_frames([&] { method.compute(views); }, {}, plan, t.setup.min_time_s));
    } catch (const cv::Exception& e) {
      t.skips.note(peer.name, g.size, method.num_disparities, "OpenCV: " + e.err);
    }
  }
}

// Times one preset on one backend, with the medians of its stages.
void time_preset(Timing& t, Group& g, const std::string& name, Backend backend, const PairViews& views) {
  FramePlan plan = frame_plan(g.size, backend == Backend::Reference, t.setup.warmup, t.setup.frames);
  MatcherOptions options;
  options.threads = g.threads_requested;
  options.device = t.setup.device;
  options.adapt_threads = !t.setup.fixed_threads;
  PresetMethod method(open_backend(backend, t.setup.device, g.size, bench_params(name, g.num_disparities), options));
  const Matcher& matcher = method.matcher();
  // A matcher that adapts its threads tries one thread after its first frames: the warm-up covers
  // that trial (at 4K, with its few frames, the trial's would otherwise be half of those timed).
  if (options.adapt_threads && matcher.backend() == Backend::Cpu && matcher.threads() > 1 && t.setup.warmup > 0)
    plan.warmup = std::max(plan.warmup, MatcherOptions::kFramesToFirstChoice);
  std::vector<std::vector<double>> stage_ms;
  const auto collect_stages = [&] {
    const std::vector<StageTime>& times = matcher.timings();
    stage_ms.resize(times.size());
    for (std::size_t s = 0; s < times.size(); ++s) stage_ms[s].push_back(times[s].ms);
  };
  Measurement m;
  m.method = name;
  m.kind = "mctstereo";
  m.backend = to_string(matcher.backend());
  m.num_disparities = g.num_disparities;
  m.threads = matcher.threads();
  m.warmup = plan.warmup;
  const TimedFrames timed =
      time_frames([&] { method.compute(views); }, collect_stages, plan, t.setup.min_time_s);
  for (std::size_t s = 0; s < stage_ms.size(); ++s)
    m.stage_median_ms.push_back({matcher.timings()[s].stage, median(stage_ms[s])});
  m.work = matcher.level_work();
  m.frames_run = plan.warmup + static_cast<long>(timed.ms.size());
  m.frames_alone = matcher.frames_alone();
  record(t, g, std::move(m), timed);
}

// The source image at a frame size: resized (stretched), or repeated at its own size and cut.
cv::Mat fit_to(const cv::Mat& source, const FrameSize& size, bool tile) {
  cv::Mat out;
  if (!tile) {
    cv::resize(source, out, cv::Size(size.width, size.height), 0, 0, cv::INTER_LINEAR);
    return out;
  }
  out.create(size.height, size.width, source.type());
  for (int y = 0; y < size.height; y += source.rows)
    for (int x = 0; x < size.width; x += source.cols) {
      const cv::Rect part(0, 0, std::min(source.cols, size.width - x), std::min(source.rows, size.height - y));
      source(part).copyTo(out(cv::Rect(x, y, part.width, part.height)));
    }
  return out;
}

// Every group: OpenCV first, then every preset on every backend (reference and opencl, single-
// threaded or on the device, in the group of the first --threads value only).
void time_groups(Timing& t, const cv::Mat& left_source, const cv::Mat& right_source) {
  const RunSetup& setup = t.setup;
  std::printf("%-10s %5s %4s  %-18s %-9s %10s %10s %9s %7s %7s %10s %6s\n", "size", "disp", "thr", "method",
              "backend", "median_ms", "p95_ms", "fps", "x BM", "frames", "mean_ms", "cores");
  std::fflush(stdout);
  for (const FrameSize& size : setup.sizes) {
    const cv::Mat left = fit_to(left_source, size, setup.tile), right = fit_to(right_source, size, setup.tile);
    for (const int num_disparities : setup.disparity_counts) {
      const std::vector<Peer> peers = make_peers(0, num_disparities);
      for (std::size_t ti = 0; ti < setup.thread_settings.size(); ++ti) {
        Group g{size, num_disparities, setup.thread_settings[ti], ""};
        g.label = size.text() + ", " + std::to_string(num_disparities) + " disparities, --threads " +
                  std::to_string(g.threads_requested) + ": ";
        cv::setNumThreads(g.threads_requested > 0 ? g.threads_requested : -1);  // -1: OpenCV's default
        const PairViews views{left, right, left, right};
        time_peers(t, g, peers, views);
        for (const Backend backend : setup.backends) {
          if ((backend == Backend::Reference || backend == Backend::OpenCL) && ti > 0) continue;
          for (const std::string& name : setup.presets) {
            t.progress.step(g.label + name + " (" + std::string(to_string(backend)) + ")");
            if (const std::string problem = preset_problem(name, size, num_disparities); !problem.empty()) {
              t.skips.note(name, size, num_disparities, problem);
              continue;
            }
            time_preset(t, g, name, backend, views);
          }
        }
      }
    }
  }
}

// The presets' frames that ran on one thread (MatcherOptions::adapt_threads), where any did.
void print_frames_alone(const std::vector<Measurement>& measurements) {
  bool any = false;
  for (const Measurement& m : measurements) {
    if (m.frames_alone == 0) continue;
    if (!any) std::printf("\nframes run on one thread (adapt_threads: trials, or one thread was faster)\n");
    any = true;
    std::printf("%-10s %5d %4d  %-18s %ld of %ld frames\n", m.size.text().c_str(), m.num_disparities, m.threads,
                m.method.c_str(), m.frames_alone, m.frames_run);
  }
}

// Stage medians, tables of their own so that the one above stays within 120 columns: one per
// list of stages (the host backends share one; opencl times its kernels).
void print_stage_tables(const std::vector<Measurement>& measurements, Progress& progress) {
  std::vector<std::vector<std::string>> stage_lists;
  for (const Measurement& m : measurements) {
    if (m.stage_median_ms.empty()) continue;
    std::vector<std::string> names;
    for (const StageTime& s : m.stage_median_ms) names.push_back(s.stage);
    if (std::find(stage_lists.begin(), stage_lists.end(), names) == stage_lists.end()) stage_lists.push_back(names);
  }
  for (const std::vector<std::string>& stage_names : stage_lists) {
    progress.clear();
    std::printf("\nper-stage medians, ms (the matcher's own times; frame = the whole call%s)\n",
                std::find(stage_names.begin(), stage_names.end(), "upload") != stage_names.end()
                    ? "; opencl: kernels' device times, host times of upload, speckle, download"
                    : "");
    std::printf("%-10s %5s %4s  %-18s %-9s", "size", "disp", "thr", "method", "backend");
    for (const std::string& s : stage_names) std::printf(" %8s", s.c_str());
    std::printf("\n");
    for (const Measurement& m : measurements) {
      if (m.stage_median_ms.size() != stage_names.size() ||
          !std::equal(stage_names.begin(), stage_names.end(), m.stage_median_ms.begin(),
                      [](const std::string& n, const StageTime& s) { return n == s.stage; }))
        continue;
      std::printf("%-10s %5d %4d  %-18s %-9s", m.size.text().c_str(), m.num_disparities, m.threads, m.method.c_str(),
                  m.backend.c_str());
      for (const StageTime& s : m.stage_median_ms) std::printf(" %8.3f", s.ms);
      std::printf("\n");
    }
    std::fflush(stdout);
  }
}

// The model of the box matching kernel's arithmetic (src/cpu/match.cpp), per vector of int16 lanes
// of one candidate: XOR and popcount of the census word in two u32 vectors and their narrowing
// (5), the vertical running sum's add and subtract over 16 rows plus the 4 rows of the window
// margin (2.5), the horizontal 5-tap sum (4), and the winner and runner-up updates (4).
constexpr double kBoxOpsPerVector = 15.5;

// Cycles per pixel-disparity pair at which the box kernel's vector ALU work alone would run on
// the SIMD target: kBoxOpsPerVector / (int16 lanes x vector ALU ports). 0 when unknown.
double box_alu_bound(const std::string& target) {
  if (target.rfind("AVX3", 0) == 0) return kBoxOpsPerVector / (32 * 2);  // 512-bit: ports 0 and 5
  if (target == "AVX2") return kBoxOpsPerVector / (16 * 3);              // 256-bit: ports 0, 1, 5
  if (target == "SSE4" || target == "SSSE3" || target == "NEON") return kBoxOpsPerVector / (8 * 2);
  return 0.0;
}

// What the matching stage costs per pixel and per pixel-disparity pair: the match stage's median
// time as thread time (wall x threads, so that 1 and 2 threads compare) over the pairs that
// level_work() counted, in ns and in cycles at the CPU's clock, next to the box kernel's ALU bound.
void print_work_table(const RunSetup& setup, const std::vector<Measurement>& measurements) {
  const double mhz = cpu_mhz();
  bool any = false;
  for (const Measurement& m : measurements) any = any || !m.work.empty();
  if (!any) return;
  std::printf("\nmatching work: candidates = disparities examined per pixel and view (finest level); pairs/px =\n"
              "pixel-disparity pairs of all levels and views per input pixel; match stage thread time (median x\n"
              "threads) per input pixel and per pair, cycles at %.0f MHz; bound = the box kernel's vector ALU work\n"
              "per pair on %s (docs/RESULTS.md, \"Roofline\")\n",
              mhz, setup.simd_target.c_str());
  std::printf("%-10s %5s %4s  %-18s %-9s %10s %8s %9s %9s %10s %7s\n", "size", "disp", "thr", "method", "backend",
              "candidates", "pairs/px", "ns/px", "ns/pair", "cyc/pair", "bound");
  for (const Measurement& m : measurements) {
    if (m.work.empty()) continue;
    double pairs = 0.0;
    for (const LevelWork& w : m.work) pairs += w.pairs();
    double match_ms = 0.0;
    for (const StageTime& s : m.stage_median_ms)
      if (s.stage == "match") match_ms = s.ms;
    const double pixels = static_cast<double>(m.size.width) * m.size.height;
    const double thread_ns = match_ms * 1e6 * m.threads;
    const double ns_pair = pairs > 0 ? thread_ns / pairs : 0.0;
    const bool box = !bench_params(m.method, m.num_disparities).sgm();
    const double bound = m.backend == "cpu" && box ? box_alu_bound(setup.simd_target) : 0.0;
    std::printf("%-10s %5d %4d  %-18s %-9s %10.2f %8.2f %9.3f %9.4f %10.3f", m.size.text().c_str(), m.num_disparities,
                m.threads, m.method.c_str(), m.backend.c_str(), m.work.front().candidates, pairs / pixels,
                thread_ns / pixels, ns_pair, ns_pair * mhz * 1e-3);
    if (bound > 0) std::printf(" %7.3f\n", bound);
    else std::printf(" %7s\n", "-");
  }
  std::fflush(stdout);
}

// The memory probes run on the cpu backend unless only the reference backend was timed, with the
// most threads asked for (the matcher holds match scratch per thread).
Backend memory_backend_of(const RunSetup& setup) {
  return setup.has(Backend::Cpu) || !setup.has(Backend::Reference) ? Backend::Cpu : Backend::Reference;
}

int memory_threads_of(const RunSetup& setup) {
  if (memory_backend_of(setup) != Backend::Cpu) return 1;
  const auto effective = [&](int t) { return t > 0 ? t : std::max(1, setup.settings.openmp_max_threads); };
  return effective(*std::max_element(setup.thread_settings.begin(), setup.thread_settings.end(),
                                     [&](int a, int b) { return effective(a) < effective(b); }));
}

// Memory: one fresh process per (size, range, preset). Host memory: the opencl backend's buffers
// live on its device.
std::vector<MemoryRecord> probe_memory(const RunSetup& setup, Progress& progress, SkipNotes& skips) {
  const Backend backend = memory_backend_of(setup);
  const int threads = memory_threads_of(setup);
  std::vector<MemoryRecord> records;
  for (const FrameSize& size : setup.sizes)
    for (const int num_disparities : setup.disparity_counts)
      for (const std::string& name : setup.presets) {
        progress.step("memory of " + name + " at " + size.text() + ", " + std::to_string(num_disparities) +
                      " disparities");
        if (!preset_problem(name, size, num_disparities).empty()) continue;  // noted above
        MatcherOptions options;
        options.threads = threads;
        MemoryRecord rec;
        rec.method = name;
        rec.backend = to_string(backend);
        rec.size = size;
        rec.num_disparities = num_disparities;
        rec.threads = threads;
        rec.estimate_bytes = estimate_memory(bench_params(name, num_disparities), size.width, size.height, options);
        std::fflush(stdout);
        const ProbeResult probe = spawn_memory_probe(probe_spec(size, num_disparities, name, backend, threads));
        if (!probe.error.empty()) {
          skips.note("memory of " + name, size, num_disparities, probe.error);
          continue;
        }
        rec.baseline_bytes = static_cast<long long>(probe.baseline_kib) * 1024;
        rec.peak_bytes = static_cast<long long>(probe.peak_kib - probe.baseline_kib) * 1024;
        rec.peak_measure = probe.measure;
        records.push_back(rec);
      }
  progress.clear();
  return records;
}

void print_memory_table(const RunSetup& setup, const std::vector<MemoryRecord>& records) {
  std::printf(
      "\nmatcher memory, MiB: peak resident memory of a fresh process that builds the matcher and matches\n"
      "one frame, over what it held just before; estimate_memory() next to it (%s backend, %d threads)\n",
      std::string(to_string(memory_backend_of(setup))).c_str(), memory_threads_of(setup));
  std::printf("%-10s %5s  %-18s %10s %12s %9s\n", "size", "disp", "method", "peak", "estimate", "peak/est");
  for (const MemoryRecord& rec : records)
    std::printf(
        "%-10s %5d  %-18s %10s %12s %9s\n", rec.size.text().c_str(), rec.num_disparities, rec.method.c_str(),
        mib(static_cast<double>(rec.peak_bytes)).c_str(), mib(static_cast<double>(rec.estimate_bytes)).c_str(),
        rec.estimate_bytes > 0 ? fixed(static_cast<double>(rec.peak_bytes) / rec.estimate_bytes, 2).c_str() : "-");
}

// The largest size: the report's memory estimates are those of its first range.
FrameSize largest_size(const RunSetup& setup) {
  return *std::max_element(setup.sizes.begin(), setup.sizes.end(),
                           [](const FrameSize& a, const FrameSize& b) { return a.pixels() < b.pixels(); });
}

Json settings_json(const RunSetup& setup) {
  Json j = Json::object();
  j.set("cpu_model", setup.settings.cpu);
  j.set("cpu_mhz", cpu_mhz());
  j.set("cores_online", setup.settings.cores_online);
  j.set("load_threads", setup.load);
  const char* spin = std::getenv("GOMP_SPINCOUNT");
  const char* policy = std::getenv("OMP_WAIT_POLICY");
  j.set("gomp_spincount", spin ? spin : "");
  j.set("omp_wait_policy", policy ? policy : "");
  j.set("simd_target", setup.simd_target);
  j.set("backend", to_string(setup.backends.front()));
  j.set("threads_requested", setup.thread_settings.front());
  j.set("threads", setup.backends.front() == Backend::Reference ? 1
                   : setup.thread_settings.front() > 0          ? setup.thread_settings.front()
                                                                : setup.settings.openmp_max_threads);
  j.set("opencv_threads", setup.first_opencv_threads);
  j.set("mctstereo_version", MCTSTEREO_VERSION);
  j.set("opencv_version", CV_VERSION);
  j.set("openmp_max_threads", setup.settings.openmp_max_threads);
  j.set("compiler", compiler_version());
  j.set("build_type", build_type());
  j.set("date", utc_date());
  Json backends = Json::array(), threads = Json::array(), disparities = Json::array(), sizes = Json::array(),
       presets = Json::array();
  for (const Backend b : setup.backends) backends.push_back(to_string(b));
  for (const int t : setup.thread_settings) threads.push_back(t);
  for (const int d : setup.disparity_counts) disparities.push_back(d);
  for (const FrameSize& s : setup.sizes) sizes.push_back(s.text());
  for (const std::string& p : setup.presets) presets.push_back(p);
  j.set("backends", std::move(backends));
  if (!setup.opencl_device.empty()) j.set("opencl_device", setup.opencl_device);
  j.set("thread_settings", std::move(threads));
  j.set("num_disparities", std::move(disparities));
  j.set("sizes", std::move(sizes));
  j.set("presets", std::move(presets));
  j.set("warmup_frames", setup.warmup);
  j.set("min_frames", setup.frames);
  j.set("min_time_s", setup.min_time_s);
  j.set("left_image", setup.left_path);
  j.set("fit", setup.tile ? "tile" : "stretch");
  j.set("memory_only", setup.memory_only);
  j.set("adapt_threads", !setup.fixed_threads);
  j.set("right_image", setup.right_path);
  return j;
}

Json measurement_json(const Measurement& m) {
  Json rec = Json::object();
  rec.set("method", m.method);
  rec.set("kind", m.kind);
  rec.set("width", m.size.width);
  rec.set("height", m.size.height);
  rec.set("num_disparities", m.num_disparities);
  rec.set("threads", m.threads);
  rec.set("frames", m.frames);
  rec.set("median_ms", m.median_ms);
  rec.set("p95_ms", m.p95_ms);
  rec.set("mean_ms", m.mean_ms);
  rec.set("fps", m.fps());
  rec.set("cpu_cores", m.cpu_cores);
  if (!m.backend.empty()) rec.set("backend", m.backend);
  rec.set("threads_requested", m.threads_requested);
  rec.set("warmup_frames", m.warmup);
  if (m.kind == "mctstereo") rec.set("frames_alone", static_cast<long long>(m.frames_alone));
  if (!m.stage_median_ms.empty()) rec.set("stage_median_ms", stage_json(m.stage_median_ms));
  if (!m.work.empty()) {
    Json levels = Json::array();
    for (const LevelWork& w : m.work) {
      Json level = Json::object();
      level.set("width", w.width);
      level.set("height", w.height);
      level.set("views", w.views);
      level.set("candidates", w.candidates);
      levels.push_back(std::move(level));
    }
    rec.set("level_work", std::move(levels));
  }
  rec.set("ratio_to_stereobm", m.ratio_to_stereobm);  // null without a StereoBM time
  return rec;
}

Json memory_record_json(const MemoryRecord& m) {
  Json rec = Json::object();
  rec.set("method", m.method);
  rec.set("width", m.size.width);
  rec.set("height", m.size.height);
  rec.set("num_disparities", m.num_disparities);
  rec.set("backend", m.backend);
  rec.set("threads", m.threads);
  rec.set("estimate_memory_bytes", m.estimate_bytes);
  rec.set("peak_resident_bytes", m.peak_bytes);
  rec.set("baseline_resident_bytes", m.baseline_bytes);
  rec.set("peak_measure", m.peak_measure);
  return rec;
}

Json memory_json(const RunSetup& setup, const std::vector<MemoryRecord>& records, long peak_kib) {
  const FrameSize largest = largest_size(setup);
  Json estimates = Json::object();
  for (const MemoryRecord& rec : records)
    if (rec.size == largest && rec.num_disparities == setup.disparity_counts.front())
      estimates.set(rec.method, rec.estimate_bytes);
  Json list = Json::array();
  for (const MemoryRecord& rec : records) list.push_back(memory_record_json(rec));
  Json memory = Json::object();
  memory.set("peak_resident_bytes", static_cast<long long>(peak_kib) * 1024);
  memory.set("estimate_size", largest.text());
  memory.set("estimate_num_disparities", setup.disparity_counts.front());
  memory.set("estimate_memory_bytes", std::move(estimates));
  memory.set("records", std::move(list));
  return memory;
}

Json json_report(const RunSetup& setup, const Timing& timing, const std::vector<MemoryRecord>& memory,
                 long peak_kib) {
  Json records = Json::array();
  for (const Measurement& m : timing.measurements) records.push_back(measurement_json(m));
  Json report = Json::object();
  report.set("settings", settings_json(setup));
  report.set("records", std::move(records));
  report.set("memory", memory_json(setup, memory, peak_kib));
  report.set("skipped", timing.skips.skipped());
  return report;
}

}  // namespace

BenchCommand::BenchCommand(CLI::App& parent)
    : command_(parent.add_subcommand("bench", "time the presets against OpenCV StereoBM and StereoSGBM")) {
  CLI::App& app = *command_;
  app.footer(kBenchFooter);
  app.add_option("--sizes", sizes_, "frame sizes WIDTHxHEIGHT, comma separated; 'thesis' = the six thesis sizes")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--num-disparities", num_disparities_, "disparities searched, from 0; comma separated (1 to 2048)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--presets", presets_, "presets to time, comma separated (default: all)")->delimiter(',');
  app.add_option("--backend", backends_,
                 "where the pipeline runs: cpu (SIMD + threads), reference (scalar), opencl (an OpenCL device), "
                 "auto (opencl on a GPU, else cpu); comma separated")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--device", device_, kDeviceHelp);
  app.add_option("--threads", threads_, "threads of the cpu backend and OpenCV, comma separated; 0 = all cores")
      ->delimiter(',')
      ->capture_default_str();
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
  app.add_option("--fit", fit_,
                 "how the pair becomes each size: stretch (resized) or tile (repeated at its own size, so that "
                 "disparities and texture per pixel stay the same at every size)")
      ->check(CLI::IsMember({"stretch", "tile"}))
      ->capture_default_str();
  app.add_option("--load", load_,
                 "busy threads of another process during the timing (0 = none): timings on a loaded CPU")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  app.add_flag("--fixed-threads", fixed_threads_,
               "run every frame of the presets on all --threads; by default a matcher runs its frames on all of them "
               "or on one, whichever its recent frames found faster (on a loaded CPU, one can be)");
  app.add_flag("--memory-only", memory_only_,
               "measure only the memory table (no timing): every size, range and preset in a fresh process");
  app.add_option("--memory-probe", memory_probe_)->group("");  // internal: see run_memory_probe
  app.add_option("--load-probe", load_probe_)->group("");      // internal: see run_load_probe
}

void BenchCommand::run() const {
  if (!memory_probe_.empty()) {
    run_memory_probe(memory_probe_);
    return;
  }
  if (load_probe_ > 0) run_load_probe(load_probe_);
  RunSetup setup;
  setup.sizes = parse_sizes(sizes_);
  setup.disparity_counts = parse_counts("--num-disparities", num_disparities_, 1, 2048);
  setup.thread_settings = parse_counts("--threads", threads_, 0, 4096);
  setup.backends = parse_backends(backends_);
  setup.presets = presets_.empty() ? preset_names() : presets_;
  for (const std::string& name : setup.presets) {
    try {
      (void)preset(name);
    } catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--presets: ") + e.what());
    }
  }
  if (image_left_.empty() != image_right_.empty())
    throw UsageError("--image-left and --image-right go together: give both or neither");
  if (!json_.empty()) check_output_path(json_, {image_left_, image_right_}, "JSON report");
  std::tie(setup.left_path, setup.right_path) =
      image_left_.empty() ? find_sample_pair(data_) : std::pair{image_left_, image_right_};
  const cv::Mat left = read_gray_image(setup.left_path, "left image");
  const cv::Mat right = read_gray_image(setup.right_path, "right image");
  if (left.size() != right.size())
    throw RuntimeError("left image " + in_quotes(setup.left_path) + " and right image " + in_quotes(setup.right_path) +
                       " differ in size");
  if (!device_.empty() && !setup.has(Backend::OpenCL) && !setup.has(Backend::Auto))
    throw UsageError("--device " + device_ + ": only --backend opencl and auto run on an OpenCL device");
  setup.device = device_;
  setup.opencl_device = resolve_backends(setup.backends, device_);
  setup.settings = probe_settings();
  setup.simd_target = setup.has(Backend::Cpu) ? setup.settings.simd_target : "scalar";
  setup.warmup = warmup_;
  setup.frames = frames_;
  setup.min_time_s = min_time_s_;
  setup.load = load_;
  setup.tile = fit_ == "tile";
  setup.memory_only = memory_only_;
  setup.fixed_threads = fixed_threads_;
  print_header(setup);

  const int presets = static_cast<int>(setup.presets.size());
  Progress progress(setup.memory_only ? static_cast<int>(setup.sizes.size() * setup.disparity_counts.size()) * presets
                                 : progress_steps(setup));
  SkipNotes skips(progress);
  Timing timing{setup, progress, skips, {}};
  cv::setNumThreads(setup.thread_settings.front() > 0 ? setup.thread_settings.front() : -1);
  setup.first_opencv_threads = cv::getNumThreads();
  if (!setup.memory_only) {
    // The load runs while every method is timed (the peers as well), and stops before the memory probes.
    std::optional<CpuLoad> load(std::in_place, load_);
    time_groups(timing, left, right);
    load.reset();
    print_frames_alone(timing.measurements);
    print_stage_tables(timing.measurements, progress);
    print_work_table(setup, timing.measurements);
  }

  const std::vector<MemoryRecord> memory = probe_memory(setup, progress, skips);
  print_memory_table(setup, memory);
  const long peak_kib = status_kib("VmHWM");
  std::printf("peak resident memory of this process (every size): %s MiB\n", mib(peak_kib * 1024.0).c_str());
  std::fflush(stdout);
  if (!json_.empty()) write_json_file(json_, json_report(setup, timing, memory, peak_kib));
}

}  // namespace mctstereo::app
