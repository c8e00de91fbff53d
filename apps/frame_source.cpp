#include "frame_source.hpp"

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "errors.hpp"
#include "io.hpp"
#include "output_files.hpp"

namespace mctstereo::app {

namespace fs = std::filesystem;

namespace {

// Where the integer conversion of a pattern is: [begin, end) of "%05d"; npos when there is none.
struct Conversion {
  std::size_t begin = std::string::npos, end = std::string::npos;
};

Conversion find_conversion(const std::string& pattern, std::string_view flag) {
  Conversion found;
  int count = 0;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') continue;
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    while (j < pattern.size() && std::string_view("-+ 0#").find(pattern[j]) != std::string_view::npos) ++j;
    while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j]))) ++j;
    if (j >= pattern.size() || std::string_view("diu").find(pattern[j]) == std::string_view::npos)
      throw UsageError(std::string(flag) + " " + in_quotes(pattern) + ": '" + pattern.substr(i, j + 1 - i) +
                       "' is not an integer conversion (use one such as %05d for the frame number, %% for a %)");
    found = {i, j + 1};
    ++count;
    i = j;
  }
  if (count != 1)
    throw UsageError(std::string(flag) + " " + in_quotes(pattern) + " has " + std::to_string(count) +
                     " integer conversions: it needs exactly one (such as %05d) for the frame number");
  return found;
}

bool is_image_name(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* known : {".png", ".jpg", ".jpeg", ".ppm", ".pgm", ".pbm", ".pnm", ".bmp", ".tif", ".tiff", ".webp"})
    if (ext == known) return true;
  return false;
}

// The image files of a folder, sorted by name; hidden files and other files are left out.
std::vector<std::string> folder_images(const std::string& folder, std::string_view flag) {
  std::vector<std::string> files;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.' || !is_image_name(entry.path())) continue;
    std::error_code type_ec;
    if (entry.is_regular_file(type_ec)) files.push_back(entry.path().string());
  }
  if (ec) throw RuntimeError("cannot list " + std::string(flag) + " folder " + in_quotes(folder) + ": " + ec.message());
  if (files.empty())
    throw RuntimeError(std::string(flag) + " folder " + in_quotes(folder) +
                       " holds no images (.png, .jpg, .ppm, .pgm, .bmp, .tif, .webp)");
  std::sort(files.begin(), files.end());
  return files;
}

// The files of a printf pattern: numbered from 0 or, when there is no file 0, from 1 (as OpenCV),
// up to the first number without a file.
std::vector<std::string> pattern_images(const std::string& pattern, std::string_view flag) {
  std::error_code ec;
  int first = 0;
  if (!fs::is_regular_file(frame_path(pattern, 0), ec)) first = 1;
  if (!fs::is_regular_file(frame_path(pattern, 1), ec) && first == 1)
    throw RuntimeError(std::string(flag) + " " + in_quotes(pattern) + ": no such files (neither " +
                       in_quotes(frame_path(pattern, 0)) + " nor " + in_quotes(frame_path(pattern, 1)) + " exists)");
  std::vector<std::string> files;
  for (int index = first;; ++index) {
    std::string path = frame_path(pattern, index);
    if (!fs::is_regular_file(path, ec)) break;
    files.push_back(std::move(path));
  }
  return files;
}

// An 8-bit gray or BGR frame, as the matcher and the preview take it.
void to_gray_or_bgr(cv::Mat& image, const std::string& what) {
  if (image.depth() != CV_8U)
    throw RuntimeError(what + " has samples that are not 8-bit; only 8-bit frames are matched");
  if (image.channels() == 4) cv::cvtColor(image, image, cv::COLOR_BGRA2BGR);
  else if (image.channels() == 2) cv::extractChannel(image, image, 0);
}

// One stream of images. grab() moves to the next image (false at the end) and retrieve() decodes
// it, so two cameras are triggered together before either image is decoded.
class ImageStream {
 public:
  virtual ~ImageStream() = default;
  virtual bool grab() = 0;
  virtual void retrieve(cv::Mat& image) = 0;
  /// The file or device of image `index`, for messages.
  virtual std::string name(int index) const = 0;
  /// Skips `count` images; false when the stream ends first.
  virtual bool skip(int count) = 0;
  /// "" when the stream ended as it may (a file); the error otherwise (a camera never ends).
  virtual std::string end_error(int frames) const = 0;
  virtual double fps() const { return 0.0; }
  virtual int count() const { return -1; }
  virtual std::vector<std::string> files() const = 0;
  virtual bool is_camera() const { return false; }
};

class SequenceStream : public ImageStream {
 public:
  SequenceStream(std::vector<std::string> files, std::string role) : files_(std::move(files)), role_(std::move(role)) {}

  bool grab() override {
    ++next_;
    return next_ <= static_cast<int>(files_.size());
  }
  void retrieve(cv::Mat& image) override {
    const std::string& path = files_[next_ - 1];
    read_input_image(path, role_).copyTo(image);  // copyTo keeps the buffer of `image` while the size stays
  }
  std::string name(int index) const override {
    return index < static_cast<int>(files_.size()) ? in_quotes(files_[index]) : "(none)";
  }
  bool skip(int count) override {
    next_ += count;
    return next_ <= static_cast<int>(files_.size());
  }
  std::string end_error(int) const override { return ""; }
  int count() const override { return static_cast<int>(files_.size()); }
  std::vector<std::string> files() const override { return files_; }

 private:
  std::vector<std::string> files_;
  std::string role_;
  int next_ = 0;  // images grabbed so far
};

// While opening a capture OpenCV tries one backend after another and logs why each one declined;
// the error that follows says it once.
class OpenCvLogSilenced {
 public:
  OpenCvLogSilenced() : previous_(cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT)) {}
  ~OpenCvLogSilenced() { cv::utils::logging::setLogLevel(previous_); }
  OpenCvLogSilenced(const OpenCvLogSilenced&) = delete;
  OpenCvLogSilenced& operator=(const OpenCvLogSilenced&) = delete;

 private:
  cv::utils::logging::LogLevel previous_;
};

// The capture backends tried, in order, of those this OpenCV has. Left to itself (CAP_ANY) OpenCV
// also tries every camera plugin it has, even for a file, and some of them leak what they
// allocated when they decline.
std::vector<cv::VideoCaptureAPIs> capture_backends(bool camera) {
  std::vector<cv::VideoCaptureAPIs> preferred = {cv::CAP_FFMPEG, cv::CAP_GSTREAMER};
#if defined(__linux__)
  if (camera) preferred = {cv::CAP_V4L2, cv::CAP_GSTREAMER};
#else
  if (camera) preferred.clear();
#endif
  std::vector<cv::VideoCaptureAPIs> available;
  for (const cv::VideoCaptureAPIs api : preferred)
    if (cv::videoio_registry::hasBackend(api)) available.push_back(api);
  if (available.empty()) available.push_back(cv::CAP_ANY);
  return available;
}

class VideoStream : public ImageStream {
 public:
  // A video file.
  VideoStream(const std::string& path, std::string_view flag) : path_(path) {
    const OpenCvLogSilenced quiet;
    for (const cv::VideoCaptureAPIs api : capture_backends(false))
      if (capture_.open(path, api)) break;
    if (!capture_.isOpened())
      throw RuntimeError("cannot open " + std::string(flag) + " video " + in_quotes(path) +
                         ": not a video that OpenCV can decode");
  }
  // A camera, by its OpenCV capture index.
  VideoStream(int camera, std::string_view flag) : camera_(camera) {
    const OpenCvLogSilenced quiet;
    for (const cv::VideoCaptureAPIs api : capture_backends(true))
      if (capture_.open(camera, api)) break;
    if (!capture_.isOpened())
      throw RuntimeError("cannot open camera " + std::to_string(camera) + " (" + std::string(flag) + ")");
  }

  // A capture opened by the caller, read as camera `camera`: its end is the camera failing.
  VideoStream(cv::VideoCapture&& capture, int camera) : camera_(camera), capture_(std::move(capture)) {
    if (!capture_.isOpened()) throw RuntimeError("camera " + std::to_string(camera) + " is not open");
  }

  bool grab() override { return capture_.grab(); }
  void retrieve(cv::Mat& image) override {
    if (!capture_.retrieve(image) || image.empty())
      throw RuntimeError("cannot decode a frame of " + name(0));
    to_gray_or_bgr(image, name(0));
  }
  std::string name(int) const override {
    return camera_ >= 0 ? "camera " + std::to_string(camera_) : "video " + in_quotes(path_);
  }
  bool skip(int count) override {
    for (int i = 0; i < count; ++i)
      if (!capture_.grab()) return false;
    return true;
  }
  std::string end_error(int frames) const override {
    if (camera_ < 0) return "";
    return "camera " + std::to_string(camera_) + " stopped delivering frames after " + std::to_string(frames) +
           " frames";
  }
  double fps() const override {
    const double fps = capture_.get(cv::CAP_PROP_FPS);
    return fps > 0.0 && fps < 1000.0 ? fps : 0.0;
  }
  int count() const override {
    if (camera_ >= 0) return -1;
    const double frames = capture_.get(cv::CAP_PROP_FRAME_COUNT);
    return frames > 0.0 ? static_cast<int>(frames) : -1;
  }
  std::vector<std::string> files() const override {
    if (camera_ >= 0) return {};
    return {path_};
  }
  bool is_camera() const override { return camera_ >= 0; }

 private:
  std::string path_;
  int camera_ = -1;
  cv::VideoCapture capture_;
};

enum class InputKind { Video, Folder, Pattern };

std::string_view kind_name(InputKind kind) {
  switch (kind) {
    case InputKind::Video: return "a video";
    case InputKind::Folder: return "a folder";
    case InputKind::Pattern: return "a printf pattern";
  }
  return "?";
}

InputKind kind_of(const std::string& path, std::string_view flag) {
  if (path.find('%') != std::string::npos) {
    check_frame_pattern(path, flag);
    return InputKind::Pattern;
  }
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status))
    throw RuntimeError("cannot open " + std::string(flag) + " " + in_quotes(path) + ": no such file or folder");
  if (fs::is_directory(status)) return InputKind::Folder;
  // A FIFO without a writer would block the video reader's open() for ever; a camera's device
  // (a character device) is a video as OpenCV reads it.
  if (fs::is_fifo(status) || fs::is_socket(status) || fs::is_block_file(status))
    throw RuntimeError("cannot open " + std::string(flag) + " " + in_quotes(path) + ": it is a " +
                       (fs::is_fifo(status) ? "FIFO" : fs::is_socket(status) ? "socket" : "block device") +
                       ", not a video file, folder or camera");
  if (cv::haveImageReader(path))
    throw UsageError(std::string(flag) + " " + in_quotes(path) +
                     " is a single image: give a folder or a printf pattern ('left_%04d.png') of an image "
                     "sequence, or use 'mctstereo match' for one pair");
  return InputKind::Video;
}

std::unique_ptr<ImageStream> open_stream(const std::string& path, InputKind kind, std::string_view flag,
                                         const std::string& role) {
  switch (kind) {
    case InputKind::Video: return std::make_unique<VideoStream>(path, flag);
    case InputKind::Folder: return std::make_unique<SequenceStream>(folder_images(path, flag), role);
    case InputKind::Pattern: return std::make_unique<SequenceStream>(pattern_images(path, flag), role);
  }
  return nullptr;
}

std::string size_text(const cv::Mat& m) { return std::to_string(m.cols) + "x" + std::to_string(m.rows); }

// Two streams, one per view.
class PairSource : public StereoSource {
 public:
  PairSource(std::unique_ptr<ImageStream> left, std::unique_ptr<ImageStream> right, std::string kind)
      : left_(std::move(left)), right_(std::move(right)), kind_(std::move(kind)) {}

  bool read(StereoFrame& frame) override {
    const bool has_left = left_->grab();
    const bool has_right = right_->grab();
    if (!has_left || !has_right) {
      for (const ImageStream* stream : {left_.get(), right_.get()}) {
        const bool ended = stream == left_.get() ? !has_left : !has_right;
        if (ended && !stream->end_error(position_).empty()) throw RuntimeError(stream->end_error(position_));
      }
      if (has_left != has_right)
        std::cerr << "mctstereo: note: " << (has_left ? right_ : left_)->name(position_) << " ends after "
                  << position_ << " frames, before " << (has_left ? left_ : right_)->name(position_)
                  << ": stopping there\n";
      return false;
    }
    left_->retrieve(frame.left);
    right_->retrieve(frame.right);
    if (frame.left.size() != frame.right.size())
      throw RuntimeError("frame " + std::to_string(position_) + ": left view " + left_->name(position_) + " is " +
                         size_text(frame.left) + " but right view " + right_->name(position_) + " is " +
                         size_text(frame.right) + ": a rectified pair has one size");
    ++position_;
    return true;
  }
  std::string describe(int index) const override {
    return left_->name(index) + " and " + right_->name(index);
  }
  double fps() const override { return left_->fps(); }
  int frame_count() const override {
    const int l = left_->count(), r = right_->count();
    return l < 0 || r < 0 ? -1 : std::min(l, r);
  }
  std::vector<std::string> input_files() const override {
    std::vector<std::string> files = left_->files();
    for (std::string& f : right_->files()) files.push_back(std::move(f));
    return files;
  }
  std::string kind() const override { return kind_; }
  void skip(int start, std::string_view flag_names) {
    if (start <= 0) return;
    const bool left_ok = left_->skip(start), right_ok = right_->skip(start);
    if (!left_ok || !right_ok)
      throw RuntimeError("--start " + std::to_string(start) + " is past the end of " + std::string(flag_names));
    position_ = start;
  }

 private:
  std::unique_ptr<ImageStream> left_, right_;
  std::string kind_;
};

// One stream whose frames hold the left view in their left half and the right view in the other.
class SideBySideSource : public StereoSource {
 public:
  SideBySideSource(std::unique_ptr<ImageStream> stream, std::string kind)
      : stream_(std::move(stream)), kind_(std::move(kind)) {}

  bool read(StereoFrame& frame) override {
    if (!stream_->grab()) {
      const std::string error = stream_->end_error(position_);
      if (!error.empty()) throw RuntimeError(error);
      return false;
    }
    stream_->retrieve(frame.whole);
    if (frame.whole.cols % 2 != 0)
      throw RuntimeError("frame " + std::to_string(position_) + " of " + stream_->name(position_) + " is " +
                         size_text(frame.whole) + ": a side-by-side frame needs an even width (two halves)");
    const int half = frame.whole.cols / 2;
    // Views of the two halves: no copy, and no buffer of their own to keep.
    frame.left = frame.whole.colRange(0, half);
    frame.right = frame.whole.colRange(half, 2 * half);
    ++position_;
    return true;
  }
  std::string describe(int index) const override { return stream_->name(index); }
  double fps() const override { return stream_->fps(); }
  int frame_count() const override { return stream_->count(); }
  std::vector<std::string> input_files() const override { return stream_->files(); }
  std::string kind() const override { return kind_; }
  void skip(int start) {
    if (start <= 0) return;
    if (!stream_->skip(start))
      throw RuntimeError("--start " + std::to_string(start) + " is past the end of " + stream_->name(0));
    position_ = start;
  }

 private:
  std::unique_ptr<ImageStream> stream_;
  std::string kind_;
};

std::string sequence_kind(InputKind kind) { return kind == InputKind::Video ? "video" : "image sequence"; }

// Where the synthetic square lies in frame `index`: its left column in the left view, top row, side.
struct SyntheticSquare {
  int x = 0, y = 0, side = 0;
};

SyntheticSquare synthetic_square(cv::Size size, int index) {
  SyntheticSquare q;
  q.side = std::max(8, std::min(size.width, size.height) / 3);
  q.y = (size.height - q.side) / 2;
  // Columns kSyntheticSquare .. width - side: the square is whole in both views.
  const int span = std::max(1, size.width - q.side - kSyntheticSquare + 1);
  q.x = kSyntheticSquare + static_cast<int>((2LL * index) % span);
  return q;
}

// A dot's brightness: a hash of its column, row and layer (0 background, 1 square), any 8-bit value.
std::uint8_t synthetic_dot(int u, int v, std::uint32_t layer) {
  std::uint32_t h = static_cast<std::uint32_t>(u) * 0x9E3779B1u ^ static_cast<std::uint32_t>(v) * 0x85EBCA77u ^
                    layer * 0xC2B2AE3Du;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  h *= 0x297A2D39u;
  h ^= h >> 15;
  return static_cast<std::uint8_t>(h >> 24);
}

// Frames made on demand: nothing is read, nothing stored but the two views being filled.
class SyntheticSource : public StereoSource {
 public:
  SyntheticSource(cv::Size size, int start) : size_(size) { position_ = start; }

  bool read(StereoFrame& frame) override {
    make_synthetic_frame(size_, position_, frame);
    ++position_;
    return true;
  }
  std::string describe(int index) const override { return "synthetic frame " + std::to_string(index); }
  std::vector<std::string> input_files() const override { return {}; }
  std::string kind() const override { return "a synthetic random-dot scene"; }

 private:
  cv::Size size_;
};

}  // namespace

cv::Size parse_synthetic_size(const std::string& spec, std::string_view flag) {
  const std::size_t x = spec.find('x');
  long side[2] = {0, 0};
  bool ok = x != std::string::npos && x > 0 && x + 1 < spec.size();
  for (int i = 0; ok && i < 2; ++i) {
    const std::string part = i == 0 ? spec.substr(0, x) : spec.substr(x + 1);
    for (const char c : part) {
      if (!std::isdigit(static_cast<unsigned char>(c))) {
        ok = false;
        break;
      }
      side[i] = std::min<long>(side[i] * 10 + (c - '0'), kSyntheticMaxSide + 1);
    }
  }
  if (!ok) throw UsageError(std::string(flag) + " " + in_quotes(spec) + ": expected WIDTHxHEIGHT, such as 320x240");
  if (side[0] < kSyntheticMinWidth || side[1] < kSyntheticMinHeight || side[0] > kSyntheticMaxSide ||
      side[1] > kSyntheticMaxSide)
    throw UsageError(std::string(flag) + " " + in_quotes(spec) + ": the width must lie in [" +
                     std::to_string(kSyntheticMinWidth) + ", " + std::to_string(kSyntheticMaxSide) +
                     "] and the height in [" + std::to_string(kSyntheticMinHeight) + ", " +
                     std::to_string(kSyntheticMaxSide) + "]");
  return {static_cast<int>(side[0]), static_cast<int>(side[1])};
}

int synthetic_disparity(cv::Size size, int index, int x, int y) {
  const SyntheticSquare q = synthetic_square(size, index);
  return x >= q.x && x < q.x + q.side && y >= q.y && y < q.y + q.side ? kSyntheticSquare : kSyntheticBackground;
}

void make_synthetic_frame(cv::Size size, int index, StereoFrame& frame) {
  const SyntheticSquare q = synthetic_square(size, index);
  frame.whole.release();
  frame.left.create(size, CV_8U);
  frame.right.create(size, CV_8U);
  for (int y = 0; y < size.height; ++y) {
    std::uint8_t* left = frame.left.ptr<std::uint8_t>(y);
    std::uint8_t* right = frame.right.ptr<std::uint8_t>(y);
    const bool square_row = y >= q.y && y < q.y + q.side;
    for (int x = 0; x < size.width; ++x) {
      // The left view's pixel x shows the square's dot x - q.x, or the background's dot x; the right
      // view's pixel x shows what lies at left column x + d: the square in front where it covers it.
      const bool in_left = square_row && x >= q.x && x < q.x + q.side;
      left[x] = in_left ? synthetic_dot(x - q.x, y - q.y, 1) : synthetic_dot(x, y, 0);
      const int xs = x + kSyntheticSquare;
      const bool in_right = square_row && xs >= q.x && xs < q.x + q.side;
      right[x] = in_right ? synthetic_dot(xs - q.x, y - q.y, 1) : synthetic_dot(x + kSyntheticBackground, y, 0);
    }
  }
}

void check_frame_pattern(const std::string& pattern, std::string_view flag) {
  const Conversion conversion = find_conversion(pattern, flag);
  const std::size_t slash = pattern.find_last_of('/');
  if (slash != std::string::npos && slash > conversion.begin)
    throw UsageError(std::string(flag) + " " + in_quotes(pattern) +
                     ": the frame number must be in the file name, not in a folder name");
}

std::string frame_path(const std::string& pattern, int index) {
  std::vector<char> buf(pattern.size() + 32);
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
#endif
  // check_frame_pattern made sure of one integer conversion and nothing else.
  const int n = std::snprintf(buf.data(), buf.size(), pattern.c_str(), index);
  if (n >= static_cast<int>(buf.size())) {
    buf.resize(static_cast<std::size_t>(n) + 1);
    std::snprintf(buf.data(), buf.size(), pattern.c_str(), index);
  }
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif
  return n < 0 ? pattern : std::string(buf.data());
}

std::unique_ptr<StereoSource> open_stereo_source(const StereoInputSpec& spec, int start) {
  const bool files = !spec.left.empty() || !spec.right.empty();
  const bool side_by_side = !spec.side_by_side.empty();
  const bool cameras = spec.left_camera >= 0 || spec.right_camera >= 0;
  const bool side_by_side_camera = spec.side_by_side_camera >= 0;
  const bool synthetic = !spec.synthetic.empty();
  const int inputs = int{files} + int{side_by_side} + int{cameras} + int{side_by_side_camera} + int{synthetic};
  if (inputs == 0)
    throw UsageError("no input: give --left and --right, --side-by-side, --left-camera and --right-camera, "
                     "--side-by-side-camera or --synthetic");
  if (inputs > 1)
    throw UsageError("give one input: --left and --right, --side-by-side, --left-camera and --right-camera, "
                     "--side-by-side-camera or --synthetic, not several of them");
  if (synthetic) return std::make_unique<SyntheticSource>(parse_synthetic_size(spec.synthetic, "--synthetic"), start);
  if ((cameras || side_by_side_camera) && start > 0)
    throw UsageError("--start skips frames of files; a camera delivers what it sees now");

  if (files) {
    if (spec.left.empty() || spec.right.empty())
      throw UsageError(std::string(spec.left.empty() ? "--right" : "--left") + " needs " +
                       (spec.left.empty() ? "--left" : "--right") +
                       " (or use --side-by-side for frames holding both views)");
    const InputKind left_kind = kind_of(spec.left, "--left");
    const InputKind right_kind = kind_of(spec.right, "--right");
    const bool left_video = left_kind == InputKind::Video, right_video = right_kind == InputKind::Video;
    if (left_video != right_video)
      throw UsageError("--left " + in_quotes(spec.left) + " is " + std::string(kind_name(left_kind)) + " but --right " +
                       in_quotes(spec.right) + " is " + std::string(kind_name(right_kind)) +
                       ": give two videos or two image sequences");
    auto left = open_stream(spec.left, left_kind, "--left", "left image");
    auto right = open_stream(spec.right, right_kind, "--right", "right image");
    if (!left_video && left->count() != right->count())
      throw RuntimeError("--left " + in_quotes(spec.left) + " holds " + std::to_string(left->count()) +
                         " images but --right " + in_quotes(spec.right) + " holds " + std::to_string(right->count()) +
                         ": the two sequences need one image per frame");
    auto source = std::make_unique<PairSource>(std::move(left), std::move(right),
                                               "two " + sequence_kind(left_kind) + "s");
    source->skip(start, "--left " + in_quotes(spec.left));
    return source;
  }
  if (side_by_side) {
    const InputKind kind = kind_of(spec.side_by_side, "--side-by-side");
    auto source = std::make_unique<SideBySideSource>(
        open_stream(spec.side_by_side, kind, "--side-by-side", "side-by-side image"),
        "a side-by-side " + sequence_kind(kind));
    source->skip(start);
    return source;
  }
  if (cameras) {
    if (spec.left_camera < 0 || spec.right_camera < 0)
      throw UsageError(std::string(spec.left_camera < 0 ? "--right-camera" : "--left-camera") + " needs " +
                       (spec.left_camera < 0 ? "--left-camera" : "--right-camera") +
                       " (or use --side-by-side-camera for a camera delivering both views in one frame)");
    if (spec.left_camera == spec.right_camera)
      throw UsageError("--left-camera and --right-camera are both camera " + std::to_string(spec.left_camera));
    auto left = std::make_unique<VideoStream>(spec.left_camera, "--left-camera");
    auto right = std::make_unique<VideoStream>(spec.right_camera, "--right-camera");
    return std::make_unique<PairSource>(std::move(left), std::move(right), "two cameras");
  }
  return std::make_unique<SideBySideSource>(
      std::make_unique<VideoStream>(spec.side_by_side_camera, "--side-by-side-camera"), "a side-by-side camera");
}

std::unique_ptr<StereoSource> camera_pair_source(cv::VideoCapture&& left, int left_index, cv::VideoCapture&& right,
                                                 int right_index) {
  return std::make_unique<PairSource>(std::make_unique<VideoStream>(std::move(left), left_index),
                                      std::make_unique<VideoStream>(std::move(right), right_index), "two cameras");
}

}  // namespace mctstereo::app
