// Stereo pairs frame by frame from two videos, one side-by-side video, two image sequences (folders
// or printf patterns) or cameras, read into buffers that are reused from frame to frame.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace mctstereo::app {

/// Where the pairs come from, as the flags of `stream` give it. Exactly one of: left and right
/// (two videos, two folders or two printf patterns), side_by_side (one video, folder or pattern
/// holding the left view in the left half of each frame), the two cameras, side_by_side_camera, or
/// synthetic ("WxH": pairs made frame by frame, see synthetic_disparity).
struct StereoInputSpec {
  std::string left, right, side_by_side, synthetic;
  int left_camera = -1, right_camera = -1, side_by_side_camera = -1;
};

/// One stereo frame. For side-by-side input `whole` holds the frame as read and `left` and
/// `right` are views of its two halves; otherwise `left` and `right` own their pixels. Reading
/// into the same frame again reuses its buffers while the size stays.
struct StereoFrame {
  cv::Mat whole, left, right;
};

/// The pairs of one input, in order. Every view is 8-bit gray or BGR.
class StereoSource {
 public:
  virtual ~StereoSource() = default;
  /// Reads the next pair into `frame`; false at the end of the input. RuntimeError for a file that
  /// cannot be read or decoded, a left and right view of different sizes, or a camera that stops
  /// delivering frames ("camera N stopped delivering frames after K frames").
  virtual bool read(StereoFrame& frame) = 0;
  /// The frames read so far, skipped ones included: the number of the next frame, counted from 0.
  int position() const { return position_; }
  /// The files the frames of `index` come from, for messages: "'l/0003.png' and 'r/0003.png'";
  /// the video or camera for other inputs.
  virtual std::string describe(int index) const = 0;
  /// Frames per second of the input when it says (a video, a camera); 0 when unknown.
  virtual double fps() const { return 0.0; }
  /// Frames of the input when known before reading (sequences; videos that say), else -1.
  virtual int frame_count() const { return -1; }
  /// Every file the input reads, for the checks that no output overwrites one.
  virtual std::vector<std::string> input_files() const = 0;
  /// What the input is, for the summary: "two image sequences", "a side-by-side video", ...
  virtual std::string kind() const = 0;

 protected:
  int position_ = 0;
};

/// Opens the input of `spec` and skips its first `start` frames. UsageError for a mix of flags that
/// makes no sense (a video and a folder, a camera and a file, --start on a camera) or a bad
/// pattern; RuntimeError when a video or camera does not open, a folder holds no images, the two
/// sequences have different lengths, or `start` is past the end.
std::unique_ptr<StereoSource> open_stereo_source(const StereoInputSpec& spec, int start);

/// Two captures the caller opened (OpenCV devices this program does not open by index, such as a
/// GStreamer pipeline) read as the cameras `left_index` and `right_index`: as for --left-camera and
/// --right-camera, a capture that stops delivering frames is a RuntimeError, not the end of input.
std::unique_ptr<StereoSource> camera_pair_source(cv::VideoCapture&& left, int left_index, cv::VideoCapture&& right,
                                                 int right_index);

/// The synthetic input (`stream --synthetic WxH`): gray random-dot pairs made frame by frame, never
/// stored, endless. A background plane at disparity kSyntheticBackground and, in front of it, a
/// square at kSyntheticSquare (a third of the smaller side, at least 8 px) that moves 2 px to the
/// right each frame and starts again on the left; the dots of the square move with it. Frame N is
/// the same on every run.
inline constexpr int kSyntheticBackground = 4;
inline constexpr int kSyntheticSquare = 12;
/// The smallest and largest sides of a synthetic frame.
inline constexpr int kSyntheticMinWidth = 48, kSyntheticMinHeight = 16, kSyntheticMaxSide = 8192;
/// The size of `spec` ("WxH", both within the bounds above); UsageError naming `flag` otherwise.
cv::Size parse_synthetic_size(const std::string& spec, std::string_view flag);
/// The exact disparity of the left view's pixel (x, y) in synthetic frame `index` of `size`:
/// kSyntheticSquare inside the square, kSyntheticBackground elsewhere.
int synthetic_disparity(cv::Size size, int index, int x, int y);
/// Synthetic frame `index` of `size` into `frame` (buffers reused while the size stays).
void make_synthetic_frame(cv::Size size, int index, StereoFrame& frame);

/// Throws UsageError unless `pattern` holds exactly one integer conversion (%d, %05d, %i, %u; %%
/// for a literal %), in its file name rather than its folder. `flag` names it in messages.
void check_frame_pattern(const std::string& pattern, std::string_view flag);
/// `pattern` (checked by check_frame_pattern) with `index` in place of its conversion.
std::string frame_path(const std::string& pattern, int index);

}  // namespace mctstereo::app
