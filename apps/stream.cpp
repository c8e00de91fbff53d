#include "stream.hpp"

#include <unistd.h>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <system_error>
#include <thread>
#include <tuple>
#include <vector>

#include "depth_files.hpp"
#include "errors.hpp"
#include "io.hpp"
#include "output_files.hpp"
#include "statistics.hpp"

namespace mctstereo::app {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

constexpr const char* kStreamFooter = R"(Inputs (one of):
  --left L --right R        two videos, two folders of images (files sorted by name, one per frame,
                            the same count) or two printf patterns ('left_%04d.png', numbered from 0,
                            or from 1 when there is no file 0, up to the first missing number)
  --side-by-side F          a video, folder or pattern whose frames hold the left view in the left
                            half and the right view in the right half
  --left-camera I --right-camera J, --side-by-side-camera I: OpenCV capture indexes
  --synthetic WxH           endless gray random-dot pairs made frame by frame (nothing read or
                            stored): background at disparity 4, a square at 12 moving 2 px a frame
  Frames are numbered from 0 in input order (--start skips some but keeps their numbers); every
  frame must have the size of the first.
Outputs (per-frame patterns take the frame number, e.g. 'out/disp_%05d.png'):
  --disparity P   one disparity file per frame, as match -o: .pfm, or .png by --format
  --depth P       one depth map per frame, as match --depth: .pfm (float, units of the baseline;
                  relative depth 1/d without a calibration) or .png (16-bit, millimetres)
  --preview-video F   left frame and colour disparity side by side (turbo over the fixed range
                  [min, min + N - 1], black = invalid): .avi (MJPG), .mkv (FFV1, lossless), .mp4;
                  read back at the end, and an error unless every frame is in it (a full disk)
  --show          the same preview in a window with the live frame rate (q or Esc stops)
Calibration (--calib FILE, or --focal and --baseline): as match. A file of the raw cameras (K1 D1
K2 D2 without "rectified: 1") has every frame rectified before matching, with maps computed once;
the outputs are then in the rectified left frame.
--temporal: each frame's finer levels also search around the previous frame's maps; where a pixel
is still (gray change <= --temporal-threshold) and those maps agree with the coarser level, the
search narrows to both (fewer candidates on a still scene); where the scene moves or cuts it stays
as without them (docs/PIPELINE.md, "Temporal prior"; every backend).
Capture, matching and writing run on their own threads; while writing is behind (its queue full),
frames are matched on one thread, which leaves the other cores to the writer. The summary line (stdout) gives the frames,
the latency from a frame's capture to its outputs being written (mean, 95th percentile), the
median matching time, the frame rate and the last frame's candidates per pixel at the finest
level. Ctrl-C (SIGINT) or SIGTERM stops after the frames in flight are written, with exit status
0; a second Ctrl-C more than 1 s later ends at once (status 130), one within 1 s is taken as the
same request.
)";

// A fixed-capacity FIFO between two threads. push() waits while full, pop() while empty; after
// close() pushes fail and pops return what is left, then nothing. No allocation after construction.
template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity) : items_(capacity) {}

  bool push(T item) {
    std::unique_lock lock(mutex_);
    not_full_.wait(lock, [&] { return closed_ || size_ < items_.size(); });
    if (closed_) return false;
    items_[(head_ + size_) % items_.size()] = std::move(item);
    ++size_;
    not_empty_.notify_one();
    return true;
  }
  std::optional<T> pop() {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [&] { return closed_ || size_ > 0; });
    if (size_ == 0) return std::nullopt;
    T item = std::move(items_[head_]);
    head_ = (head_ + 1) % items_.size();
    --size_;
    not_full_.notify_one();
    return item;
  }
  /// Whether a push() would wait now.
  bool full() {
    std::lock_guard lock(mutex_);
    return size_ == items_.size();
  }
  void close() {
    std::lock_guard lock(mutex_);
    closed_ = true;
    not_full_.notify_all();
    not_empty_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable not_full_, not_empty_;
  std::vector<T> items_;
  std::size_t head_ = 0, size_ = 0;
  bool closed_ = false;
};

// Samples of a long run in bounded memory: every value while there are at most kCapacity, then a
// uniform sample of them (reservoir sampling with a fixed seed), so order statistics stay exact for
// short runs and close for long ones; the mean is exact.
class Samples {
 public:
  static constexpr std::size_t kCapacity = 1 << 14;
  Samples() { values_.reserve(kCapacity); }
  void add(double v) {
    ++count_;
    sum_ += v;
    if (values_.size() < kCapacity) {
      values_.push_back(v);
      return;
    }
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    const std::uint64_t slot = (state_ >> 11) % count_;
    if (slot < kCapacity) values_[slot] = v;
  }
  double mean() const { return count_ == 0 ? 0.0 : sum_ / static_cast<double>(count_); }
  const std::vector<double>& values() const { return values_; }

 private:
  std::vector<double> values_;
  std::uint64_t count_ = 0, state_ = 0x853c49e6748fea9bULL;
  double sum_ = 0.0;
};

// SIGINT and SIGTERM set a flag that the capture stage polls; a second one ends the process at once
// (the capture may be blocked on a camera that delivers nothing), removing the preview video's
// temporary first. A second signal within kRepeatGraceNs (1 s) of the first is the same request
// delivered twice: `timeout -s INT` signals the process and then its group, and a terminal's
// Ctrl-C reaches every process of the group.
std::atomic<int> g_stop_signal{0};
std::atomic<std::int64_t> g_first_stop_ns{0};
constexpr std::int64_t kRepeatGraceNs = 1'000'000'000;
char g_temporary_video[4096];                       // whole while g_temporary_video_set is true
std::atomic<bool> g_temporary_video_set{false};

std::int64_t monotonic_ns() {  // clock_gettime is async-signal-safe; steady_clock need not be
  timespec now {};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

extern "C" void on_stop_signal(int signal) {
  if (g_stop_signal.load() == 0) {
    g_first_stop_ns.store(monotonic_ns());
    g_stop_signal.store(signal);
    return;
  }
  if (monotonic_ns() - g_first_stop_ns.load() <= kRepeatGraceNs) return;
  if (g_temporary_video_set.load()) ::unlink(g_temporary_video);  // async-signal-safe, as _exit
  ::_exit(128 + signal);
}

class StopSignals {
 public:
  StopSignals() {
    g_stop_signal.store(0);
    g_first_stop_ns.store(0);
    struct sigaction action {};
    action.sa_handler = on_stop_signal;
    sigemptyset(&action.sa_mask);
    ::sigaction(SIGINT, &action, &previous_int_);
    ::sigaction(SIGTERM, &action, &previous_term_);
  }
  ~StopSignals() {
    ::sigaction(SIGINT, &previous_int_, nullptr);
    ::sigaction(SIGTERM, &previous_term_, nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction previous_int_ {};
  struct sigaction previous_term_ {};
};

// One frame on its way through the stages. The slots are made once and passed around, so a long
// run reuses the same buffers.
struct FrameSlot {
  int index = 0;  // frame number in the input
  StereoFrame frame;
  cv::Mat left_rectified, right_rectified;  // the frame rectified, when the calibration asks for it
  const cv::Mat* left = nullptr;            // the views that are matched: the frame's or the rectified ones
  const cv::Mat* right = nullptr;
  cv::Mat disparity_q4;  // CV_16SC1 copy of the matcher's map, which the next frame overwrites
  double matching_ms = 0.0;
  Clock::time_point captured;
};

// capture holds one slot, each queue up to kQueueDepth, matching one and writing one: with that
// many slots no stage waits for a buffer, only for a neighbour.
constexpr std::size_t kQueueDepth = 2;
constexpr std::size_t kSlots = 2 * kQueueDepth + 3;

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

MapView<const std::int16_t> map_view(const cv::Mat& q4) {
  return {q4.ptr<std::int16_t>(), q4.cols, q4.rows, static_cast<std::ptrdiff_t>(q4.step[0] / sizeof(std::int16_t))};
}

void copy_map(MapView<const std::int16_t> from, cv::Mat& to) {
  for (int y = 0; y < from.height; ++y) std::copy_n(from.row(y), from.width, to.ptr<std::int16_t>(y));
}

// The codec of a preview video, by the extension of its name.
int preview_fourcc(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".avi") return cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
  if (ext == ".mkv") return cv::VideoWriter::fourcc('F', 'F', 'V', '1');
  if (ext == ".mp4") return cv::VideoWriter::fourcc('m', 'p', '4', 'v');
  throw UsageError("--preview-video " + in_quotes(path) +
                   ": name it .avi (MJPG), .mkv (FFV1, lossless) or .mp4 (MPEG-4)");
}

// The preview video, written to a temporary next to its destination (with its extension, which
// chooses the container) and renamed into place once read back whole: OpenCV's writer reports no
// failed write, so a full disk would otherwise leave a truncated video behind a success. Reading
// back decodes each frame once, far less work than matching it. A temporary not finished is removed.
class PreviewVideo {
 public:
  PreviewVideo(const std::string& path, int fourcc, double fps, cv::Size size)
      : path_(path), destination_(regular_output_file(path, "preview video")) {
    temporary_ = destination_.parent_path() / ("." + destination_.stem().string() + ".tmp-" +
                                               std::to_string(::getpid()) + destination_.extension().string());
    const std::string name = fs::absolute(temporary_).string();
    if (name.size() < sizeof g_temporary_video) {
      std::memcpy(g_temporary_video, name.c_str(), name.size() + 1);
      g_temporary_video_set.store(true);
    }
    writer_.open(temporary_.string(), cv::CAP_FFMPEG, fourcc, fps, size, true);
    if (!writer_.isOpened()) {
      remove_temporary();
      const fs::path folder = destination_.parent_path().empty() ? fs::path(".") : destination_.parent_path();
      if (::access(folder.c_str(), W_OK) != 0)
        throw RuntimeError("cannot write preview video " + in_quotes(path) + ": " + std::strerror(errno));
      throw RuntimeError("cannot write preview video " + in_quotes(path) + ": OpenCV has no encoder for it here");
    }
  }
  ~PreviewVideo() {
    writer_.release();
    remove_temporary();
  }
  PreviewVideo(const PreviewVideo&) = delete;
  PreviewVideo& operator=(const PreviewVideo&) = delete;

  void write(const cv::Mat& frame) {
    writer_.write(frame);
    ++frames_;
  }
  /// Closes the video, checks that every frame written reads back, and renames it into place.
  void finish() {
    writer_.release();
    const int found = frames_in(temporary_);
    if (found != frames_)
      throw RuntimeError("cannot write preview video " + in_quotes(path_) + ": " + std::to_string(found) + " of its " +
                         std::to_string(frames_) + " frames read back (is the disk full?)");
    std::error_code ec;
    fs::rename(temporary_, destination_, ec);
    if (ec) throw RuntimeError("cannot write preview video " + in_quotes(path_) + ": " + ec.message());
    g_temporary_video_set.store(false);
    temporary_.clear();
  }

 private:
  static int frames_in(const fs::path& video) {
    const StderrSilenced quiet;  // FFmpeg's own words on a truncated file ("overread 8")
    cv::VideoCapture capture;
    try {
      if (!capture.open(video.string(), cv::CAP_FFMPEG)) return 0;
    } catch (const cv::Exception&) {
      return 0;
    }
    int frames = 0;
    while (capture.grab()) ++frames;
    return frames;
  }
  void remove_temporary() {
    g_temporary_video_set.store(false);
    std::error_code ec;
    if (!temporary_.empty()) fs::remove(temporary_, ec);
  }

  std::string path_;
  fs::path destination_, temporary_;
  cv::VideoWriter writer_;
  int frames_ = 0;
};

// Why a window cannot be shown; "" when it can.
std::string display_problem() {
  const char* x11 = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((x11 == nullptr || *x11 == '\0') && (wayland == nullptr || *wayland == '\0'))
    return "there is no display (DISPLAY and WAYLAND_DISPLAY are not set)";
  // The build information has a line "GUI: NAME", NONE without a GUI backend.
  std::istringstream info(cv::getBuildInformation());
  for (std::string line; std::getline(info, line);) {
    const std::size_t at = line.find("GUI:");
    if (at == std::string::npos) continue;
    if (line.find("NONE", at) != std::string::npos) return "this OpenCV has no GUI backend";
    break;
  }
  return "";
}

// The canonical names of the input files, so an output that would replace one is caught whatever
// way its path is spelt.
class InputNames {
 public:
  explicit InputNames(const std::vector<std::string>& inputs) {
    for (const std::string& input : inputs) names_.insert(canonical(input));
  }
  void check(const std::string& output, std::string_view flag, const std::string& pattern) const {
    if (names_.count(canonical(output)) != 0)
      throw UsageError(std::string(flag) + " " + in_quotes(pattern) + " would write " + in_quotes(output) +
                       ", an input: refusing to overwrite an input");
  }

 private:
  static std::string canonical(const std::string& path) { return canonical_name(path).string(); }
  std::set<std::string> names_;
};

// Progress on stderr: one line rewritten in place on a terminal, a line every few seconds otherwise.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), terminal_(::isatty(STDERR_FILENO) == 1) {}
  void update(int frames, double fps, double latency_ms) {
    if (!enabled_) return;
    const Clock::time_point now = Clock::now();
    if (now - last_ < (terminal_ ? std::chrono::milliseconds(250) : std::chrono::milliseconds(5000))) return;
    last_ = now;
    const std::string line = std::to_string(frames) + " frames, " + fixed(fps, 1) + " fps, latency " +
                             fixed(latency_ms, 1) + " ms";
    // One write per line, so nothing else lands inside it.
    if (terminal_) {
      std::cerr << ("\r" + line + "\033[K") << std::flush;
      shown_ = true;
    } else {
      std::cerr << ("mctstereo: " + line + "\n") << std::flush;
    }
  }
  void finish() {
    if (shown_) std::cerr << "\r\033[K" << std::flush;
    shown_ = false;
  }

 private:
  bool enabled_, terminal_;
  bool shown_ = false;
  Clock::time_point last_ = Clock::now();
};

}  // namespace

StreamCommand::StreamCommand(CLI::App& parent)
    : command_(parent.add_subcommand("stream", "match a stream of rectified stereo pairs: videos, image sequences "
                                               "or cameras")),
      parameters_(*command_) {
  CLI::App& app = *command_;
  app.footer(kStreamFooter);
  const char* input_group = "Input";
  app.add_option("--left", input_.left, "left view: a video, a folder of images or a printf pattern")
      ->group(input_group);
  app.add_option("--right", input_.right, "right view, of the same kind as --left")->group(input_group);
  app.add_option("--side-by-side", input_.side_by_side,
                 "one video, folder or pattern of frames holding both views side by side")
      ->group(input_group);
  app.add_option("--left-camera", input_.left_camera, "OpenCV capture index of the left camera")
      ->check(CLI::NonNegativeNumber)
      ->group(input_group);
  app.add_option("--right-camera", input_.right_camera, "OpenCV capture index of the right camera")
      ->check(CLI::NonNegativeNumber)
      ->group(input_group);
  app.add_option("--side-by-side-camera", input_.side_by_side_camera,
                 "OpenCV capture index of a camera delivering both views side by side")
      ->check(CLI::NonNegativeNumber)
      ->group(input_group);
  app.add_option("--synthetic", input_.synthetic,
                 "WxH: endless gray random-dot pairs made frame by frame (background at disparity 4, a moving "
                 "square at 12), for tests and soak runs")
      ->group(input_group);
  app.add_option("--start", start_, "skip the first N frames (files only)")
      ->check(CLI::NonNegativeNumber)
      ->group(input_group);
  app.add_option("--max-frames", max_frames_, "stop after N frames (0 = all)")
      ->check(CLI::NonNegativeNumber)
      ->group(input_group);
  const char* output_group = "Output";
  app.add_option("--disparity", disparity_, "per-frame disparity files, a printf pattern: 'out/disp_%05d.png'")
      ->group(output_group);
  app.add_option("--format", format_,
                 "encoding of .png disparity files: kitti (256 x d, default) or q4 (16 x (d - min + 1)); pfm")
      ->check(CLI::IsMember({"kitti", "q4", "pfm"}))
      ->group(output_group);
  app.add_option("--depth", depth_,
                 "per-frame depth maps, a printf pattern: .pfm (units of the baseline; 1/d without a calibration) "
                 "or .png (16-bit, millimetres)")
      ->group(output_group);
  app.add_option("--max-depth", max_depth_, "leave out of --depth what lies deeper than Z (units of the baseline)")
      ->check(positive_number())
      ->group(output_group);
  app.add_option("--preview-video", preview_video_,
                 "video of the left frame and the colour disparity side by side (.avi, .mkv, .mp4)")
      ->group(output_group);
  app.add_flag("--show", show_, "show the preview and the frame rate in a window when there is a display")
      ->group(output_group);
  app.add_flag("--quiet", quiet_, "no progress on stderr")->group(output_group);
  const char* temporal_group = "Temporal prior";
  app.add_flag("--temporal", temporal_,
               "the finer levels also search around the previous frame's map: fewer candidates where the scene "
               "holds still, the same search where it moves or cuts (cpu backend)")
      ->group(temporal_group);
  app.add_option("--temporal-radius", temporal_radius_,
                 "radius of the temporal prior's narrowed bands, pixels; [0, 16] (default 1)")
      ->group(temporal_group);
  app.add_option("--temporal-threshold", temporal_threshold_,
                 "a pixel whose gray value changed by more than this since the previous frame has moved and takes "
                 "no temporal prior; above the cameras' noise; [0, 255] (default 12)")
      ->group(temporal_group);
  calibration_flags_.add_to(app);
  run_flags_.add_to(app);
}

namespace {

// The flags of one run, as the units below read them.
struct StreamSettings {
  std::string disparity, format, depth, preview_video;
  double max_depth = 0.0;  // 0 = no cut
  int start = 0, max_frames = 0;
  bool show = false, quiet = false;
};

// What the flags ask of the outputs, checked before any input is opened.
struct OutputPlan {
  std::optional<DisparityFormat> format;  // per-frame disparity files
  DepthFormat depth_format = DepthFormat::Pfm;
  int fourcc = 0;     // of the preview video
  bool show = false;  // a window (false where there is no display: progress on stderr instead)
};

OutputPlan plan_outputs(const StreamSettings& s, const StereoParams& requested, bool calibrated) {
  OutputPlan plan;
  if (!s.disparity.empty()) {
    check_frame_pattern(s.disparity, "--disparity");
    plan.format = disparity_format_for(s.disparity, s.format);
    check_format_range(*plan.format, requested, s.disparity);
  } else if (!s.format.empty()) {
    throw UsageError("--format " + s.format + " applies to --disparity files, and none were asked for");
  }
  if (!s.depth.empty()) {
    check_frame_pattern(s.depth, "--depth");
    plan.depth_format = depth_format_for(s.depth);
    if (plan.depth_format == DepthFormat::PngMillimetres && !calibrated)
      throw UsageError("--depth " + in_quotes(s.depth) +
                       ": a PNG depth map holds millimetres and needs a calibration: give --calib FILE or --focal and "
                       "--baseline (or write relative depth 1/d to .pfm files)");
  }
  if (s.max_depth > 0.0) {
    if (s.depth.empty()) throw UsageError("--max-depth cuts --depth, which was not given");
    if (!calibrated)
      throw UsageError("--max-depth is in the units of the baseline and needs a calibration: give --calib FILE or "
                       "--focal and --baseline");
  }
  if (!s.preview_video.empty()) plan.fourcc = preview_fourcc(s.preview_video);
  check_distinct_outputs({{"--disparity", s.disparity}, {"--depth", s.depth}, {"--preview-video", s.preview_video}});
  plan.show = s.show;
  if (plan.show) {
    const std::string problem = display_problem();
    if (!problem.empty()) {
      std::cerr << "mctstereo: note: --show: " << problem << "; showing progress on stderr instead\n";
      plan.show = false;
    }
  }
  return plan;
}

// No output may replace an input: every frame's name is checked now when the length is known,
// and again as each frame is written (through the names returned). A per-frame file is renamed
// into place, which replaces a name and leaves a file of other names (a hard link) as it was, so
// comparing canonical names suffices; the preview video is compared by file as well.
InputNames check_output_names(const StreamSettings& s, const StereoSource& source,
                              const std::vector<std::string>& calibration_files) {
  std::vector<std::string> inputs = source.input_files();
  inputs.insert(inputs.end(), calibration_files.begin(), calibration_files.end());
  InputNames input_names(inputs);
  const int first_index = source.position();
  const int count = source.frame_count();
  const int last = s.max_frames > 0 && (count < 0 || first_index + s.max_frames < count) ? first_index + s.max_frames
                                                                                        : count;
  for (const auto& [flag, pattern, what] : {std::tuple{"--disparity", &s.disparity, "disparity output"},
                                            std::tuple{"--depth", &s.depth, "depth output"}}) {
    if (pattern->empty()) continue;
    check_output_path(frame_path(*pattern, first_index), {}, what);
    for (int index = first_index; index < last; ++index) input_names.check(frame_path(*pattern, index), flag, *pattern);
  }
  if (!s.disparity.empty() && !s.depth.empty())
    check_distinct_outputs({{"--disparity", frame_path(s.disparity, first_index)},
                            {"--depth", frame_path(s.depth, first_index)}});  // '%d' and '%1d' name the same files
  if (!s.preview_video.empty()) {
    check_output_path(s.preview_video, inputs, "preview video");
    (void)regular_output_file(s.preview_video, "preview video");
  }
  return input_names;
}

// The geometry of the frames. A calibration of the raw cameras: every frame is remapped into the
// rectified frame, with maps made once, and the geometry becomes that of the rectified cameras.
struct StreamGeometry {
  std::optional<Calibration> calibration;
  std::optional<Rectifier> rectifier;
  std::string rectified_note;  // for the summary
};

StreamGeometry prepare_geometry(const CalibrationFlags& flags, const StreamSettings& s, const OutputPlan& plan,
                                const StereoSource& source, int first_index, int width, int height) {
  StreamGeometry g;
  g.calibration =
      flags.resolve(width, height, "frame " + std::to_string(first_index) + " (" + source.describe(first_index) + ")");
  if (g.calibration && g.calibration->needs_rectification) {
    g.rectifier.emplace(*g.calibration, width, height);
    g.calibration->geometry = g.rectifier->geometry();
    g.rectified_note = ", rectified with " + in_quotes(g.calibration->source);
  }
  if (g.calibration && !s.depth.empty() && plan.depth_format == DepthFormat::PngMillimetres)
    (void)millimetres_per_unit(g.calibration->geometry.units);  // a unit a PNG of millimetres cannot convert
  if (!s.depth.empty() && !g.calibration)
    std::cerr << "mctstereo: note: no calibration: " << in_quotes(s.depth)
              << " holds relative depth 1/d; give --calib FILE or --focal and --baseline for depth in units\n";
  return g;
}

// What a run measured, for the summary line.
struct StreamTotals {
  int frames_written = 0;
  double seconds = 0.0;
  Samples latency_ms, matching_ms;
  std::string end_reason;
};

// The frames through capture, matching and writing. Capture and matching run on their own
// threads; writing (and the window, which GUI toolkits want on the main thread) runs on the
// caller's. The first slot holds the frame already read.
class FramePipeline {
 public:
  FramePipeline(const StreamSettings& settings, const OutputPlan& plan, const StreamGeometry& geometry,
                const InputNames& input_names, StereoSource& source, Matcher& matcher, std::vector<FrameSlot>& slots)
      : s_(settings),
        plan_(plan),
        geometry_(geometry),
        input_names_(input_names),
        source_(source),
        matcher_(matcher),
        slots_(slots),
        width_(slots[0].frame.left.cols),
        height_(slots[0].frame.left.rows),
        free_slots_(kSlots),
        to_match_(kQueueDepth),
        to_write_(kQueueDepth),
        progress_(!settings.quiet && !plan.show) {
    for (FrameSlot& slot : slots_) slot.disparity_q4.create(height_, width_, CV_16SC1);
    for (std::size_t i = 1; i < slots_.size(); ++i) free_slots_.push(&slots_[i]);
    if (!s_.preview_video.empty())
      preview_video_.emplace(s_.preview_video, plan.fourcc, source.fps() > 0.0 ? source.fps() : 30.0,
                             cv::Size(2 * width_, height_));
    if (preview_video_ || plan.show) preview_.create(height_, 2 * width_, CV_8UC3);
    if (!s_.depth.empty()) depth_.create(height_, width_, CV_32FC1);
  }

  // Runs the frames to the end of the input, a stop or an error, finishes the preview video and
  // rethrows the first error.
  StreamTotals run() {
    if (plan_.show) cv::namedWindow(kWindow, cv::WINDOW_AUTOSIZE);
    {
      // Joined before anything they use goes away, whatever happens here.
      struct Joiner {
        std::vector<std::thread> threads;
        FramePipeline* pipeline;
        ~Joiner() {
          pipeline->close_all();
          for (std::thread& t : threads)
            if (t.joinable()) t.join();
        }
      } joiner{{}, this};
      started_ = Clock::now();
      try {
        joiner.threads.emplace_back([this] { capture(); });
        joiner.threads.emplace_back([this] { match(); });
      } catch (const std::system_error& e) {
        throw RuntimeError(std::string("cannot start the capture and matching threads: ") + e.what() +
                           " (memory limit?)");
      }
      try {
        while (const std::optional<FrameSlot*> slot = to_write_.pop()) write(**slot);
      } catch (...) {
        fail(std::current_exception());
      }
    }
    totals_.seconds = std::chrono::duration<double>(Clock::now() - started_).count();
    totals_.end_reason = end_reason_;
    progress_.finish();
    if (plan_.show) cv::destroyWindow(kWindow);
    // The frames written before an error make a whole video too; the first failure is the one told.
    if (preview_video_) {
      try {
        preview_video_->finish();
      } catch (...) {
        if (!error_) throw;
      }
    }
    if (error_) std::rethrow_exception(error_);
    return std::move(totals_);
  }

 private:
  static constexpr const char* kWindow = "mctstereo stream";

  void fail(std::exception_ptr e) {
    std::lock_guard lock(error_mutex_);
    if (!error_) error_ = e;
  }
  void close_all() {
    aborted_.store(true);
    free_slots_.close();
    to_match_.close();
    to_write_.close();
  }

  // The views of a slot that are matched, rectified first when the calibration asks for it.
  void prepare(FrameSlot& slot) {
    if (geometry_.rectifier) {
      geometry_.rectifier->rectify(slot.frame.left, slot.frame.right, slot.left_rectified, slot.right_rectified);
      slot.left = &slot.left_rectified;
      slot.right = &slot.right_rectified;
    } else {
      slot.left = &slot.frame.left;
      slot.right = &slot.frame.right;
    }
  }

  // Why capture stops before the input ends, or "" to go on.
  std::string stop_reason(int frames) const {
    if (s_.max_frames > 0 && frames >= s_.max_frames) return "--max-frames " + std::to_string(s_.max_frames);
    if (const int signal = g_stop_signal.load(); signal != 0)
      return signal == SIGINT ? "stopped by SIGINT" : "stopped by SIGTERM";
    if (user_stop_.load()) return "stopped from the window";
    return {};
  }

  // The capture thread: reads frames into free slots until the input ends or a stop.
  void capture() {
    try {
      FrameSlot& first = slots_[0];
      prepare(first);
      first.captured = Clock::now();
      int frames = 1;
      if (to_match_.push(&first)) {
        for (;;) {
          if (std::string reason = stop_reason(frames); !reason.empty()) {
            end_reason_ = std::move(reason);
            break;
          }
          if (aborted_.load()) break;
          const std::optional<FrameSlot*> slot = free_slots_.pop();
          if (!slot) break;
          const int index = source_.position();
          if (!source_.read((*slot)->frame)) {
            end_reason_ = "end of input";
            break;
          }
          const cv::Mat& left = (*slot)->frame.left;
          if (left.cols != width_ || left.rows != height_)
            throw RuntimeError("frame " + std::to_string(index) + " (" + source_.describe(index) + ") is " +
                               size_text(left.cols, left.rows) + " but the stream began at " +
                               size_text(width_, height_) + ": every frame must have the size of the first");
          prepare(**slot);
          (*slot)->index = index;
          (*slot)->captured = Clock::now();
          ++frames;
          if (!to_match_.push(*slot)) break;
        }
      }
    } catch (...) {
      fail(std::current_exception());
    }
    to_match_.close();
  }

  // The matching thread.
  void match() {
    try {
      while (const std::optional<FrameSlot*> slot = to_match_.pop()) {
        if (aborted_.load()) break;
        // With the writer behind, this frame will wait for it whatever the matching takes, and the
        // matcher's other threads would take CPU from the writer: match it on this thread alone.
        // (Measured with PNGs and an FFV1 preview on 2 cores: 2 matcher threads gave 3 % fewer
        // frames per second than 1; a camera-bound or matching-bound stream keeps its threads.)
        matcher_.set_single_threaded(to_write_.full());
        matcher_.compute(image_view(*(*slot)->left), image_view(*(*slot)->right));
        copy_map(matcher_.disparity_q4(), (*slot)->disparity_q4);
        (*slot)->matching_ms = matcher_.timings().back().ms;
        if (!to_write_.push(*slot)) break;
      }
    } catch (...) {
      fail(std::current_exception());
      aborted_.store(true);
      free_slots_.close();
      to_match_.close();
    }
    to_write_.close();
  }

  // The files of one frame (they appear together), its preview, the window and the statistics.
  void write(FrameSlot& slot) {
    const MapView<const std::int16_t> q4 = map_view(slot.disparity_q4);
    const StereoParams& params = matcher_.params();
    const std::int16_t invalid = matcher_.invalid_q4();
    PendingOutputs outputs;
    if (plan_.format) {
      const std::string path = frame_path(s_.disparity, slot.index);
      input_names_.check(path, "--disparity", s_.disparity);
      outputs.add(path, encode_disparity(q4, invalid, params.min_disparity, *plan_.format));
    }
    if (!s_.depth.empty()) {
      const std::string path = frame_path(s_.depth, slot.index);
      input_names_.check(path, "--depth", s_.depth);
      const MapView<float> depth{depth_.ptr<float>(), width_, height_, width_};
      const std::optional<Calibration>& calibration = geometry_.calibration;
      const double max_depth = s_.max_depth > 0.0 ? s_.max_depth : std::numeric_limits<double>::infinity();
      if (calibration) depth_from_disparity(q4, invalid, calibration->geometry, depth, max_depth);
      else relative_depth_from_disparity(q4, invalid, depth);
      outputs.add(path, encode_depth(MapView<const float>{depth.data, width_, height_, width_},
                                     calibration ? calibration->geometry.units : "", plan_.depth_format));
    }
    outputs.commit();
    if (!preview_.empty()) {
      cv::Mat left_half = preview_.colRange(0, width_), right_half = preview_.colRange(width_, 2 * width_);
      if (slot.left->channels() == 1) cv::cvtColor(*slot.left, left_half, cv::COLOR_GRAY2BGR);
      else slot.left->copyTo(left_half);
      render_preview(q4, invalid, params.min_disparity, params.max_disparity(), colour_);
      colour_.copyTo(right_half);
      if (preview_video_) preview_video_->write(preview_);
    }
    ++totals_.frames_written;
    const double latency = std::chrono::duration<double, std::milli>(Clock::now() - slot.captured).count();
    totals_.latency_ms.add(latency);
    totals_.matching_ms.add(slot.matching_ms);
    const double seconds = std::chrono::duration<double>(Clock::now() - started_).count();
    const double fps = seconds > 0.0 ? totals_.frames_written / seconds : 0.0;
    if (plan_.show) show(fps);
    progress_.update(totals_.frames_written, fps, latency);
    free_slots_.push(&slot);
  }

  void show(double fps) {
    cv::putText(preview_, fixed(fps, 1) + " fps", cv::Point(8, 24), cv::FONT_HERSHEY_SIMPLEX, 0.7,
                cv::Scalar(255, 255, 255), 2);
    cv::imshow(kWindow, preview_);
    const int key = cv::waitKey(1);
    if (key == 'q' || key == 27 || cv::getWindowProperty(kWindow, cv::WND_PROP_VISIBLE) < 1.0) user_stop_.store(true);
  }

  const StreamSettings& s_;
  const OutputPlan& plan_;
  const StreamGeometry& geometry_;
  const InputNames& input_names_;
  StereoSource& source_;
  Matcher& matcher_;
  std::vector<FrameSlot>& slots_;
  const int width_, height_;
  BoundedQueue<FrameSlot*> free_slots_, to_match_, to_write_;
  std::mutex error_mutex_;
  std::exception_ptr error_;
  std::atomic<bool> aborted_{false};    // an error downstream: stop reading and matching
  std::atomic<bool> user_stop_{false};  // the window was closed, or q or Esc pressed
  std::string end_reason_;              // written by the capture thread before it closes to_match_
  std::optional<PreviewVideo> preview_video_;
  cv::Mat preview_, colour_, depth_;
  Progress progress_;
  Clock::time_point started_;
  StreamTotals totals_;
};

// The candidates per pixel of the last frame's finest level (host backends), and with the
// temporal prior whether that frame used it (every backend).
std::string finest_candidates(const Matcher& matcher, const StereoParams& params) {
  const std::vector<LevelWork> work = matcher.level_work();
  const std::string temporal =
      !params.temporal ? "" : matcher.used_temporal_prior() ? "temporal prior" : "temporal prior not used";
  if (work.empty()) return temporal.empty() ? "" : "; last frame: " + temporal;
  std::string text = "; last frame: " + fixed(work.front().candidates, 2) + " candidates per pixel at the finest level";
  if (!temporal.empty()) text += " (" + temporal + ")";
  return text;
}

// The summary line on stdout.
void print_summary(const StreamSettings& s, const OutputPlan& plan, const StreamGeometry& geometry,
                   const StreamTotals& totals, const StereoSource& source, const Matcher& matcher,
                   const std::string& preset_name) {
  const StereoParams& params = matcher.params();
  const int frames = totals.frames_written;
  std::string wrote;
  if (plan.format)
    wrote += "; wrote " + std::to_string(frames) + " disparity files " + in_quotes(s.disparity) + " (" +
             describe_format(*plan.format, params.min_disparity) + ")";
  if (!s.depth.empty()) {
    const std::optional<Calibration>& calibration = geometry.calibration;
    wrote += (wrote.empty() ? "; wrote " : ", ") + std::to_string(frames) + " depth files " + in_quotes(s.depth) +
             (!calibration ? " (relative depth 1/d PFM, +INF = none)"
              : plan.depth_format == DepthFormat::Pfm
                  ? " (depth PFM, " + calibration->geometry.units + ", +INF = none)"
                  : std::string(" (depth 16-bit PNG, mm, 0 = none)"));
  }
  if (!s.preview_video.empty())
    wrote += (wrote.empty() ? "; wrote " : ", ") + std::string("preview video ") + in_quotes(s.preview_video) +
             " (left frame | disparity)";
  const std::string where = matcher.backend() == Backend::OpenCL ? ", device " + matcher.device_name() : "";
  const int width = matcher.width(), height = matcher.height();
  std::cout << frames << " frames " << size_text(width, height) << " from " << source.kind() << ", disparities "
            << params.min_disparity << ".." << params.max_disparity() << " (" << params.num_disparities
            << "), preset " << preset_name << geometry.rectified_note << ", backend " << to_string(matcher.backend())
            << where << "; latency ms: mean " << fixed(totals.latency_ms.mean(), 2) << " p95 "
            << fixed(percentile(totals.latency_ms.values(), 95.0), 2) << "; matching ms: median "
            << fixed(median(totals.matching_ms.values()), 2) << "; "
            << fixed(totals.seconds > 0.0 ? frames / totals.seconds : 0.0, 1) << " fps; " << totals.end_reason << wrote
            << finest_candidates(matcher, params) << "\n";
}

}  // namespace

void StreamCommand::run() const {
  StereoParams requested = parameters_.resolve();
  if ((temporal_radius_ || temporal_threshold_) && !temporal_)
    throw UsageError(std::string(temporal_radius_ ? "--temporal-radius" : "--temporal-threshold") +
                     " applies to --temporal, which was not given");
  requested.temporal = temporal_;
  if (temporal_radius_) requested.temporal_radius = *temporal_radius_;
  if (temporal_threshold_) requested.temporal_threshold = *temporal_threshold_;
  check_parameters(requested);
  (void)run_flags_.parsed_backend();
  const StreamSettings settings{disparity_, format_, depth_, preview_video_, max_depth_,
                                start_,     max_frames_, show_, quiet_};

  // Every check of the outputs that needs no input comes first.
  const OutputPlan plan = plan_outputs(settings, requested, calibration_flags_.given());
  // OpenCV's own warnings (a backend that did not open a file) would repeat our one-line errors.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  const std::unique_ptr<StereoSource> source = open_stereo_source(input_, start_);
  const InputNames input_names = check_output_names(settings, *source, calibration_flags_.files());

  const StopSignals stop_signals;
  std::vector<FrameSlot> slots(kSlots);
  FrameSlot& first = slots[0];
  const int first_index = source->position();
  if (!source->read(first.frame))
    throw RuntimeError(start_ > 0 ? "--start " + std::to_string(start_) + " leaves no frames of the input"
                                  : "the input holds no frames");
  first.index = first_index;
  const int width = first.frame.left.cols, height = first.frame.left.rows;
  check_parameters(requested, width, height);
  const StreamGeometry geometry =
      prepare_geometry(calibration_flags_, settings, plan, *source, first_index, width, height);
  Matcher matcher = run_flags_.make_matcher(width, height, requested);

  FramePipeline pipeline(settings, plan, geometry, input_names, *source, matcher, slots);
  const StreamTotals totals = pipeline.run();
  print_summary(settings, plan, geometry, totals, *source, matcher, parameters_.preset_name());
}

}  // namespace mctstereo::app
