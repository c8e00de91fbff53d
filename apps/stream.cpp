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
Capture, matching and writing run on their own threads. The summary line (stdout) gives the frames,
the latency from a frame's capture to its outputs being written (mean, 95th percentile), the
median matching time and the frame rate. Ctrl-C (SIGINT) or SIGTERM stops after the frames in
flight are written, with exit status 0; a second Ctrl-C more than 1 s later ends at once (status
130), one within 1 s is taken as the same request.
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
  calibration_flags_.add_to(app);
  run_flags_.add_to(app);
}

void StreamCommand::run() const {
  const StereoParams requested = parameters_.resolve();
  check_parameters(requested);
  (void)run_flags_.parsed_backend();

  // Every check of the outputs that needs no input comes first.
  std::optional<DisparityFormat> format;
  if (!disparity_.empty()) {
    check_frame_pattern(disparity_, "--disparity");
    format = disparity_format_for(disparity_, format_);
    check_format_range(*format, requested, disparity_);
  } else if (!format_.empty()) {
    throw UsageError("--format " + format_ + " applies to --disparity files, and none were asked for");
  }
  const bool calibrated = calibration_flags_.given();
  DepthFormat depth_format = DepthFormat::Pfm;
  if (!depth_.empty()) {
    check_frame_pattern(depth_, "--depth");
    depth_format = depth_format_for(depth_);
    if (depth_format == DepthFormat::PngMillimetres && !calibrated)
      throw UsageError("--depth " + in_quotes(depth_) +
                       ": a PNG depth map holds millimetres and needs a calibration: give --calib FILE or --focal and "
                       "--baseline (or write relative depth 1/d to .pfm files)");
  }
  if (max_depth_ > 0.0) {
    if (depth_.empty()) throw UsageError("--max-depth cuts --depth, which was not given");
    if (!calibrated)
      throw UsageError("--max-depth is in the units of the baseline and needs a calibration: give --calib FILE or "
                       "--focal and --baseline");
  }
  int fourcc = 0;
  if (!preview_video_.empty()) fourcc = preview_fourcc(preview_video_);
  check_distinct_outputs({{"--disparity", disparity_}, {"--depth", depth_}, {"--preview-video", preview_video_}});
  bool show = show_;
  if (show) {
    const std::string problem = display_problem();
    if (!problem.empty()) {
      std::cerr << "mctstereo: note: --show: " << problem << "; showing progress on stderr instead\n";
      show = false;
    }
  }

  // OpenCV's own warnings (a backend that did not open a file) would repeat our one-line errors.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  const std::unique_ptr<StereoSource> source = open_stereo_source(input_, start_);

  // No output may replace an input: every frame's name is checked now when the length is known,
  // and again as each frame is written. A per-frame file is renamed into place, which replaces a
  // name and leaves a file of other names (a hard link) as it was, so comparing canonical names
  // suffices; the preview video is compared by file as well.
  std::vector<std::string> inputs = source->input_files();
  for (const std::string& file : calibration_flags_.files()) inputs.push_back(file);
  const InputNames input_names(inputs);
  const int first_index = source->position();
  const int count = source->frame_count();
  const int last = max_frames_ > 0 && (count < 0 || first_index + max_frames_ < count) ? first_index + max_frames_
                                                                                        : count;
  for (const auto& [flag, pattern, what] : {std::tuple{"--disparity", &disparity_, "disparity output"},
                                            std::tuple{"--depth", &depth_, "depth output"}}) {
    if (pattern->empty()) continue;
    check_output_path(frame_path(*pattern, first_index), {}, what);
    for (int index = first_index; index < last; ++index) input_names.check(frame_path(*pattern, index), flag, *pattern);
  }
  if (!disparity_.empty() && !depth_.empty())
    check_distinct_outputs({{"--disparity", frame_path(disparity_, first_index)},
                            {"--depth", frame_path(depth_, first_index)}});  // '%d' and '%1d' name the same files
  if (!preview_video_.empty()) {
    check_output_path(preview_video_, inputs, "preview video");
    (void)regular_output_file(preview_video_, "preview video");
  }

  const StopSignals stop_signals;
  std::vector<FrameSlot> slots(kSlots);
  FrameSlot& first = slots[0];
  if (!source->read(first.frame))
    throw RuntimeError(start_ > 0 ? "--start " + std::to_string(start_) + " leaves no frames of the input"
                                  : "the input holds no frames");
  first.index = first_index;
  const int width = first.frame.left.cols, height = first.frame.left.rows;
  check_parameters(requested, width, height);
  // A calibration of the raw cameras: every frame is remapped into the rectified frame, with maps
  // made once, and the geometry becomes that of the rectified cameras.
  std::optional<Calibration> calibration =
      calibration_flags_.resolve(width, height, "frame " + std::to_string(first_index) + " (" +
                                                    source->describe(first_index) + ")");
  std::optional<Rectifier> rectifier;
  std::string rectified_note;
  if (calibration && calibration->needs_rectification) {
    rectifier.emplace(*calibration, width, height);
    calibration->geometry = rectifier->geometry();
    rectified_note = ", rectified with " + in_quotes(calibration->source);
  }
  if (calibration && !depth_.empty() && depth_format == DepthFormat::PngMillimetres)
    (void)millimetres_per_unit(calibration->geometry.units);  // a unit a PNG of millimetres cannot convert
  if (!depth_.empty() && !calibration)
    std::cerr << "mctstereo: note: no calibration: " << in_quotes(depth_)
              << " holds relative depth 1/d; give --calib FILE or --focal and --baseline for depth in units\n";
  Matcher matcher = run_flags_.make_matcher(width, height, requested);
  const StereoParams& params = matcher.params();
  const std::int16_t invalid = matcher.invalid_q4();
  for (FrameSlot& slot : slots) slot.disparity_q4.create(height, width, CV_16SC1);

  std::optional<PreviewVideo> preview_video;
  if (!preview_video_.empty())
    preview_video.emplace(preview_video_, fourcc, source->fps() > 0.0 ? source->fps() : 30.0,
                          cv::Size(2 * width, height));
  const char* const kWindow = "mctstereo stream";
  if (show) cv::namedWindow(kWindow, cv::WINDOW_AUTOSIZE);

  // The stages. Capture and matching run on their own threads; writing (and the window, which
  // GUI toolkits want on the main thread) runs here.
  BoundedQueue<FrameSlot*> free_slots(kSlots), to_match(kQueueDepth), to_write(kQueueDepth);
  for (std::size_t i = 1; i < slots.size(); ++i) free_slots.push(&slots[i]);
  std::mutex error_mutex;
  std::exception_ptr error;
  auto fail = [&](std::exception_ptr e) {
    std::lock_guard lock(error_mutex);
    if (!error) error = e;
  };
  std::atomic<bool> aborted{false};  // an error downstream: stop reading and matching
  std::atomic<bool> user_stop{false};  // the window was closed, or q or Esc pressed
  std::string end_reason;  // written by the capture thread before it closes to_match
  const int max_frames = max_frames_;

  // The views of a slot that are matched, rectified first when the calibration asks for it.
  auto prepare = [&](FrameSlot& slot) {
    if (rectifier) {
      rectifier->rectify(slot.frame.left, slot.frame.right, slot.left_rectified, slot.right_rectified);
      slot.left = &slot.left_rectified;
      slot.right = &slot.right_rectified;
    } else {
      slot.left = &slot.frame.left;
      slot.right = &slot.frame.right;
    }
  };

  auto capture = [&] {
    try {
      prepare(first);
      first.captured = Clock::now();
      int frames = 1;
      if (to_match.push(&first)) {
        for (;;) {
          if (max_frames > 0 && frames >= max_frames) {
            end_reason = "--max-frames " + std::to_string(max_frames);
            break;
          }
          if (const int signal = g_stop_signal.load(); signal != 0) {
            end_reason = signal == SIGINT ? "stopped by SIGINT" : "stopped by SIGTERM";
            break;
          }
          if (user_stop.load()) {
            end_reason = "stopped from the window";
            break;
          }
          if (aborted.load()) break;
          const std::optional<FrameSlot*> slot = free_slots.pop();
          if (!slot) break;
          const int index = source->position();
          if (!source->read((*slot)->frame)) {
            end_reason = "end of input";
            break;
          }
          const cv::Mat& left = (*slot)->frame.left;
          if (left.cols != width || left.rows != height)
            throw RuntimeError("frame " + std::to_string(index) + " (" + source->describe(index) + ") is " +
                               size_text(left.cols, left.rows) + " but the stream began at " +
                               size_text(width, height) + ": every frame must have the size of the first");
          prepare(**slot);
          (*slot)->index = index;
          (*slot)->captured = Clock::now();
          ++frames;
          if (!to_match.push(*slot)) break;
        }
      }
    } catch (...) {
      fail(std::current_exception());
    }
    to_match.close();
  };

  auto match = [&] {
    try {
      while (const std::optional<FrameSlot*> slot = to_match.pop()) {
        if (aborted.load()) break;
        matcher.compute(image_view(*(*slot)->left), image_view(*(*slot)->right));
        copy_map(matcher.disparity_q4(), (*slot)->disparity_q4);
        (*slot)->matching_ms = matcher.timings().back().ms;
        if (!to_write.push(*slot)) break;
      }
    } catch (...) {
      fail(std::current_exception());
      aborted.store(true);
      free_slots.close();
      to_match.close();
    }
    to_write.close();
  };

  Samples latency_ms, matching_ms;
  int frames_written = 0;
  Progress progress(!quiet_ && !show);
  cv::Mat preview, colour;
  if (preview_video || show) preview.create(height, 2 * width, CV_8UC3);
  cv::Mat depth;
  if (!depth_.empty()) depth.create(height, width, CV_32FC1);
  const MapView<float> depth_view{depth.ptr<float>(), width, height, width};
  const double max_depth = max_depth_ > 0.0 ? max_depth_ : std::numeric_limits<double>::infinity();
  Clock::time_point started;
  {
    // Joined before anything they use goes away, whatever happens here.
    struct Joiner {
      std::vector<std::thread> threads;
      std::function<void()> close_all;
      ~Joiner() {
        close_all();
        for (std::thread& t : threads)
          if (t.joinable()) t.join();
      }
    } joiner;
    joiner.close_all = [&] {
      aborted.store(true);
      free_slots.close();
      to_match.close();
      to_write.close();
    };
    started = Clock::now();
    try {
      joiner.threads.emplace_back(capture);
      joiner.threads.emplace_back(match);
    } catch (const std::system_error& e) {
      throw RuntimeError(std::string("cannot start the capture and matching threads: ") + e.what() +
                         " (memory limit?)");
    }
    try {
      while (const std::optional<FrameSlot*> slot = to_write.pop()) {
        FrameSlot& s = **slot;
        const MapView<const std::int16_t> q4 = map_view(s.disparity_q4);
        // The files of a frame appear together.
        PendingOutputs outputs;
        if (format) {
          const std::string path = frame_path(disparity_, s.index);
          input_names.check(path, "--disparity", disparity_);
          outputs.add(path, encode_disparity(q4, invalid, params.min_disparity, *format));
        }
        if (!depth_.empty()) {
          const std::string path = frame_path(depth_, s.index);
          input_names.check(path, "--depth", depth_);
          if (calibration) depth_from_disparity(q4, invalid, calibration->geometry, depth_view, max_depth);
          else relative_depth_from_disparity(q4, invalid, depth_view);
          outputs.add(path, encode_depth(MapView<const float>{depth_view.data, width, height, width},
                                         calibration ? calibration->geometry.units : "", depth_format));
        }
        outputs.commit();
        if (!preview.empty()) {
          cv::Mat left_half = preview.colRange(0, width), right_half = preview.colRange(width, 2 * width);
          if (s.left->channels() == 1) cv::cvtColor(*s.left, left_half, cv::COLOR_GRAY2BGR);
          else s.left->copyTo(left_half);
          render_preview(q4, invalid, params.min_disparity, params.max_disparity(), colour);
          colour.copyTo(right_half);
          if (preview_video) preview_video->write(preview);
        }
        ++frames_written;
        const double latency = std::chrono::duration<double, std::milli>(Clock::now() - s.captured).count();
        latency_ms.add(latency);
        matching_ms.add(s.matching_ms);
        const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
        const double fps = seconds > 0.0 ? frames_written / seconds : 0.0;
        if (show) {
          cv::putText(preview, fixed(fps, 1) + " fps", cv::Point(8, 24), cv::FONT_HERSHEY_SIMPLEX, 0.7,
                      cv::Scalar(255, 255, 255), 2);
          cv::imshow(kWindow, preview);
          const int key = cv::waitKey(1);
          if (key == 'q' || key == 27 || cv::getWindowProperty(kWindow, cv::WND_PROP_VISIBLE) < 1.0)
            user_stop.store(true);
        }
        progress.update(frames_written, fps, latency);
        free_slots.push(&s);
      }
    } catch (...) {
      fail(std::current_exception());
    }
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  progress.finish();
  if (show) cv::destroyWindow(kWindow);
  // The frames written before an error make a whole video too; the first failure is the one told.
  if (preview_video) {
    try {
      preview_video->finish();
    } catch (...) {
      if (!error) throw;
    }
  }
  if (error) std::rethrow_exception(error);

  std::string wrote;
  if (format)
    wrote += "; wrote " + std::to_string(frames_written) + " disparity files " + in_quotes(disparity_) + " (" +
             describe_format(*format, params.min_disparity) + ")";
  if (!depth_.empty())
    wrote += (wrote.empty() ? "; wrote " : ", ") + std::to_string(frames_written) + " depth files " +
             in_quotes(depth_) +
             (!calibration ? " (relative depth 1/d PFM, +INF = none)"
              : depth_format == DepthFormat::Pfm ? " (depth PFM, " + calibration->geometry.units + ", +INF = none)"
                                                 : std::string(" (depth 16-bit PNG, mm, 0 = none)"));
  if (!preview_video_.empty())
    wrote += (wrote.empty() ? "; wrote " : ", ") + std::string("preview video ") + in_quotes(preview_video_) +
             " (left frame | disparity)";
  const std::string where = matcher.backend() == Backend::OpenCL ? ", device " + matcher.device_name() : "";
  std::cout << frames_written << " frames " << size_text(width, height) << " from " << source->kind()
            << ", disparities " << params.min_disparity << ".." << params.max_disparity() << " ("
            << params.num_disparities << "), preset " << parameters_.preset_name() << rectified_note << ", backend "
            << to_string(matcher.backend()) << where << "; latency ms: mean " << fixed(latency_ms.mean(), 2)
            << " p95 " << fixed(percentile(latency_ms.values(), 95.0), 2) << "; matching ms: median "
            << fixed(median(matching_ms.values()), 2) << "; "
            << fixed(seconds > 0.0 ? frames_written / seconds : 0.0, 1) << " fps; " << end_reason << wrote << "\n";
}

}  // namespace mctstereo::app
