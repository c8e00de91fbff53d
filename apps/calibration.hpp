// Stereo calibration for the command line: reading it (Middlebury calib.txt, OpenCV stereo YAML or
// XML, flags), writing it back, rectifying unrectified pairs, and checking how well a pair is
// rectified.
#pragma once

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "mctstereo/depth.hpp"

namespace mctstereo::app {

/// A stereo calibration as a file or the flags give it.
struct Calibration {
  /// The geometry of the rectified pair (focal, cx, cy, baseline, doffs, units). For an
  /// unrectified rig it is the geometry after rectification (from P1, P2 or stereoRectify).
  StereoGeometry geometry;
  /// Image size the calibration was made for; 0 x 0 when unknown (flags only).
  int width = 0, height = 0;
  /// The images are those of the raw rig and must be rectified first (OpenCV files with K1, D1,
  /// K2, D2 that do not say `rectified: 1`; see read_calibration).
  /// R1, R2, P1, P2 and Q are those of the file when it has them, else computed by stereoRectify.
  bool needs_rectification = false;
  cv::Mat K1, D1, K2, D2, R, T, R1, R2, P1, P2, Q;
  /// Disparity range of the scene when the file gives it (Middlebury ndisp, vmin, vmax); 0 = unknown.
  int ndisp = 0;
  /// Where it came from, for messages: the file name, or "flags".
  std::string source;
};

/// Reads a calibration file, by its content: Middlebury calib.txt (cam0=[f 0 cx; 0 f cy; 0 0 1],
/// cam1, doffs, baseline, width, height, ndisp, ...) or an OpenCV FileStorage file (.yml, .yaml,
/// .xml, .json) holding K1, D1, K2, D2, R, T and/or R1, R2, P1, P2, Q, with image_width and
/// image_height (or width/height). Middlebury baselines are in millimetres; OpenCV translations in
/// the unit of the calibration target, assumed metres unless the file has a "units" string.
/// RuntimeError naming the file and the missing or malformed key.
///
/// Middlebury: focal, cx, cy from cam0; doffs from the file, else cam1's cx minus cam0's cx.
/// OpenCV files (M1, M2 are read as K1, K2, as OpenCV's stereo_calib sample writes them):
/// - the geometry comes from P1 and P2 (focal = P1(0,0), cx = P1(0,2), cy = P1(1,2),
///   baseline = -P2(0,3) / P2(0,0), doffs = P2(0,2) - P1(0,2)). Without P1, P2 in the file, a
///   file with K1, D1, K2, D2, R, T gets them (and R1, R2, Q where it lacks them) from
///   cv::stereoRectify (alpha 0, CALIB_ZERO_DISPARITY), which needs the image size; any other file
///   needs Q (cx = -Q(0,3), cy = -Q(1,3), focal = Q(2,3), baseline = 1 / Q(3,2),
///   doffs = Q(3,3) baseline). Only left-right pairs: a vertical P2 is refused.
/// - needs_rectification: a file holding the raw cameras (K1, D1, K2, D2) is for images as the
///   cameras took them, which must be rectified (with R1, R2, P1, P2); `rectified: 1` in the file
///   says the images are rectified already. A file without K1, D1, K2, D2 is for rectified images.
///
/// image_width x image_height (both > 0, or 0 for unknown) is the size of the images the calibration
/// is used for: a file without an image size (OpenCV's stereo_calib sample writes none) takes it, so
/// that stereoRectify and the rectification maps have one; a file with a size keeps its own (see
/// check_calibration_fits).
Calibration read_calibration(const std::string& path, int image_width = 0, int image_height = 0);
/// Several OpenCV FileStorage files read as one, such as the intrinsics.yml (M1 D1 M2 D2) and
/// extrinsics.yml (R T R1 R2 P1 P2 Q) of OpenCV's stereo_calib sample: each key comes from the first
/// file that has it; messages name the files as "A + B". A Middlebury calib.txt is whole and is read
/// alone. One path is read_calibration(path, ...).
Calibration read_calibration(const std::vector<std::string>& paths, int image_width = 0, int image_height = 0);

/// Writes `calibration` as an OpenCV YAML file that read_calibration reads back to the same values
/// (to rounding): image size, units, ndisp, the raw cameras and R1, R2 when it has them, with
/// `rectified` 0 or 1, and P1, P2, Q made from the geometry.
void write_calibration(const std::string& path, const Calibration& calibration);

/// RuntimeError when the calibration was made for another image size than width x height (the
/// rectification maps and the geometry would be wrong), naming both sizes and `image`. A scaled
/// size is refused as well: a scaled image needs the calibration of its own size.
void check_calibration_fits(const Calibration& calibration, int width, int height, const std::string& image);

/// Why `text` is not a finite number: "is not a number" (a word, an empty text, nan), "is too large"
/// (inf, or beyond a double) or "is too small (below 2.22507e-308)" (closer to 0 than the smallest
/// normal double); "" when it is one, stored in `value`.
std::string number_problem(const std::string& text, double& value);

/// A check of CLI11 for flags that take a positive finite number ("must be a positive number, not X").
const CLI::Validator& positive_number();

/// --calib FILE (given twice: the two files read as one) and the plain flags --focal, --baseline, --cx, --cy, --doffs, --units. Flags
/// override the file's values; without a file, --focal and --baseline are needed and cx, cy
/// default to the image centre ((width - 1) / 2, (height - 1) / 2), doffs to 0. --units names the
/// unit of --baseline (default: the file's unit, else m); with --calib and no --baseline, the file's
/// baseline is converted into --units.
class CalibrationFlags {
 public:
  void add_to(CLI::App& app);
  /// Whether any calibration was given.
  bool given() const;
  /// The --calib files (none without one): inputs, which no output may overwrite.
  const std::vector<std::string>& files() const { return files_; }
  /// The calibration of the flags for images of width x height (`image` names them in messages);
  /// std::nullopt when none was given. UsageError for an incomplete or invalid set of flags;
  /// RuntimeError from read_calibration or check_calibration_fits.
  std::optional<Calibration> resolve(int width, int height, const std::string& image = "the image") const;

 private:
  std::vector<std::string> files_;
  std::optional<double> focal_, baseline_, cx_, cy_, doffs_;
  std::string units_;
};

/// Rectification of an unrectified rig: the maps are computed once, then every frame is remapped.
class Rectifier {
 public:
  /// For images of width x height, with the calibration's R1, R2, P1, P2 when it has them, else
  /// those of cv::stereoRectify (zero disparity at infinity, only valid pixels kept). RuntimeError
  /// when the calibration does not fit the size, lacks K1, K2 or R, T, or the cameras are not side
  /// by side with the right one on the right.
  Rectifier(const Calibration& calibration, int width, int height);
  /// Remaps a pair into the rectified frame (`left_out` and `right_out` are reused between frames;
  /// they must not be the inputs). RuntimeError when the images are not of the size given.
  void rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat& left_out, cv::Mat& right_out) const;
  /// The geometry of the rectified pair.
  const StereoGeometry& geometry() const { return geometry_; }

 private:
  cv::Mat left_x_, left_y_, right_x_, right_y_;
  StereoGeometry geometry_;
};

/// How well a pair is rectified, from matched features: in a rectified pair a scene point lies on
/// the same row in both views, so the vertical offsets of good matches should be near 0.
struct RectificationReport {
  int features_left = 0, features_right = 0;
  int matches = 0;              ///< matches kept (mutual best, ratio test, plausible offsets, not outliers)
  int outliers = 0;             ///< matches dropped as mismatches: dy far from the median of the others
  int negative_disparities = 0;  ///< kept matches with x_left < x_right (most of them: a swapped pair)
  double median_dx = 0.0;       ///< median of the disparity x_left - x_right, pixels
  double median_dy = 0.0;       ///< median of (y_right - y_left), pixels
  double median_abs_dy = 0.0;   ///< median of |y_right - y_left|
  double p95_abs_dy = 0.0;      ///< 95th percentile of |y_right - y_left|
  double max_abs_dy = 0.0;
  /// One line: "rectified" (median |dy| <= 0.5 px), "slightly off" (<= 1.5 px) or "not rectified",
  /// with what it means for matching.
  std::string verdict;
};

/// Detects and matches features (ORB) between the two views and measures their vertical offsets.
/// RuntimeError when too few features match to say anything (fewer than 8), naming the reason.
RectificationReport check_rectification(const cv::Mat& left, const cv::Mat& right);

}  // namespace mctstereo::app
