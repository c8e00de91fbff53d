// Rectification of a calibrated rig, and a measure of how well a pair is rectified.
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "calibration.hpp"
#include "errors.hpp"
#include "statistics.hpp"

namespace mctstereo::app {

namespace {

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// `m` as a rows x cols CV_64F matrix; RuntimeError naming `key` and the calibration when it has another shape.
cv::Mat matrix_of(const cv::Mat& m, int rows, int cols, const char* key, const Calibration& calibration) {
  if (m.rows != rows || m.cols != cols || m.channels() != 1)
    throw RuntimeError("calibration '" + calibration.source + "': " + key + " is " + size_text(m.cols, m.rows) +
                       " (columns x rows), expected " + size_text(cols, rows));
  cv::Mat d;
  m.convertTo(d, CV_64F);
  return d;
}

// Distortion coefficients as one row (4, 5, 8, 12 or 14 values, as OpenCV takes them); none = no distortion.
cv::Mat distortion_of(const cv::Mat& d, const char* key, const Calibration& calibration) {
  if (d.empty()) return cv::Mat::zeros(1, 5, CV_64F);
  const int n = static_cast<int>(d.total());
  if (d.channels() != 1 || (n != 4 && n != 5 && n != 8 && n != 12 && n != 14))
    throw RuntimeError("calibration '" + calibration.source + "': " + key + " has " + std::to_string(n) +
                       " values, expected 4, 5, 8, 12 or 14 distortion coefficients");
  cv::Mat row;
  d.reshape(1, 1).convertTo(row, CV_64F);
  return row;
}

// The rotation between the cameras: a 3 x 3 matrix, or a rotation vector (3 values) as Rodrigues writes it.
cv::Mat rotation_of(const Calibration& calibration) {
  if (calibration.R.total() != 3) return matrix_of(calibration.R, 3, 3, "R", calibration);
  cv::Mat vector, matrix;
  calibration.R.reshape(1, 3).convertTo(vector, CV_64F);
  cv::Rodrigues(vector, matrix);
  return matrix;
}

cv::Mat gray_of(const cv::Mat& image, const char* view) {
  if (image.empty()) throw RuntimeError(std::string("the ") + view + " image is empty");
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else if (image.channels() == 4)
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  else
    gray = image;
  if (gray.depth() != CV_8U) {
    // 16-bit or float images: scale their range to 8 bits, which is all the detector takes.
    double lo = 0, hi = 0;
    cv::minMaxLoc(gray, &lo, &hi);
    gray.convertTo(gray, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0, hi > lo ? -lo * 255.0 / (hi - lo) : 0.0);
  }
  return gray;
}

// The offset of the parabola through (-1, a), (0, b), (1, c) at its extremum, in [-0.5, 0.5].
double parabola_peak(double a, double b, double c) {
  const double denominator = a - 2.0 * b + c;
  if (denominator >= 0.0) return 0.0;
  return std::clamp(0.5 * (a - c) / denominator, -0.5, 0.5);
}

// Sub-pixel position in `right` of the patch of `left` centred on the integer pixel `pl`, searched
// around `pr`. Feature detectors place corners on whole pixels of their pyramid level, too coarse
// to measure a few tenths of a pixel; normalised cross-correlation with a parabola through the
// peak is not. False when the patch leaves an image or the correlation is weak or at the border of
// the search window (the detector positions are then kept).
bool refine_match(const cv::Mat& left, const cv::Mat& right, cv::Point pl, cv::Point pr, cv::Point2d& refined) {
  constexpr int kHalfPatch = 7, kSearch = 3;
  const cv::Rect patch(pl.x - kHalfPatch, pl.y - kHalfPatch, 2 * kHalfPatch + 1, 2 * kHalfPatch + 1);
  const int reach = kHalfPatch + kSearch;
  const cv::Rect window(pr.x - reach, pr.y - reach, 2 * reach + 1, 2 * reach + 1);
  const cv::Rect left_bounds(0, 0, left.cols, left.rows), right_bounds(0, 0, right.cols, right.rows);
  if ((patch & left_bounds) != patch || (window & right_bounds) != window) return false;
  cv::Mat score;
  cv::matchTemplate(right(window), left(patch), score, cv::TM_CCOEFF_NORMED);
  double best = 0;
  cv::Point at;
  cv::minMaxLoc(score, nullptr, &best, nullptr, &at);
  if (!(best >= 0.8) || at.x == 0 || at.y == 0 || at.x == score.cols - 1 || at.y == score.rows - 1) return false;
  const auto s = [&](int x, int y) { return static_cast<double>(score.at<float>(y, x)); };
  const double dx = parabola_peak(s(at.x - 1, at.y), s(at.x, at.y), s(at.x + 1, at.y));
  const double dy = parabola_peak(s(at.x, at.y - 1), s(at.x, at.y), s(at.x, at.y + 1));
  refined = {pr.x - kSearch + at.x + dx, pr.y - kSearch + at.y + dy};
  return true;
}

}  // namespace

Rectifier::Rectifier(const Calibration& calibration, int width, int height) {
  if (width <= 0 || height <= 0) throw RuntimeError("cannot rectify images of " + size_text(width, height));
  if (calibration.width > 0 && calibration.height > 0 &&
      (calibration.width != width || calibration.height != height))
    throw RuntimeError("calibration '" + calibration.source + "' was made for " +
                       size_text(calibration.width, calibration.height) + " images but the images are " +
                       size_text(width, height) + ": the rectification would be wrong");
  if (calibration.K1.empty() || calibration.K2.empty())
    throw RuntimeError("calibration '" + calibration.source +
                       "' has no camera matrices K1 and K2: it cannot rectify images (it describes a rectified pair)");
  const cv::Mat K1 = matrix_of(calibration.K1, 3, 3, "K1", calibration);
  const cv::Mat K2 = matrix_of(calibration.K2, 3, 3, "K2", calibration);
  const cv::Mat D1 = distortion_of(calibration.D1, "D1", calibration);
  const cv::Mat D2 = distortion_of(calibration.D2, "D2", calibration);
  const cv::Size size(width, height);

  cv::Mat R1, R2, P1, P2;
  if (!calibration.R1.empty() && !calibration.R2.empty() && !calibration.P1.empty() && !calibration.P2.empty()) {
    R1 = matrix_of(calibration.R1, 3, 3, "R1", calibration);
    R2 = matrix_of(calibration.R2, 3, 3, "R2", calibration);
    P1 = matrix_of(calibration.P1, 3, 4, "P1", calibration);
    P2 = matrix_of(calibration.P2, 3, 4, "P2", calibration);
  } else {
    if (calibration.R.empty() || calibration.T.empty())
      throw RuntimeError("calibration '" + calibration.source +
                         "' has neither R1, R2, P1, P2 nor the rotation R and translation T between the cameras");
    const cv::Mat R = rotation_of(calibration);
    if (calibration.T.total() != 3 || calibration.T.channels() != 1)
      throw RuntimeError("calibration '" + calibration.source + "': T has " + std::to_string(calibration.T.total()) +
                         " values, expected 3");
    cv::Mat T;
    calibration.T.reshape(1, 3).convertTo(T, CV_64F);
    cv::Mat Q;
    // Zero disparity at infinity (doffs = 0) and alpha 0: only valid pixels in the rectified views.
    cv::stereoRectify(K1, D1, K2, D2, size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0);
  }

  geometry_.focal = P1.at<double>(0, 0);
  geometry_.cx = P1.at<double>(0, 2);
  geometry_.cy = P1.at<double>(1, 2);
  geometry_.doffs = P2.at<double>(0, 2) - P1.at<double>(0, 2);
  geometry_.baseline = P2.at<double>(0, 0) != 0.0 ? -P2.at<double>(0, 3) / P2.at<double>(0, 0) : 0.0;
  geometry_.units = calibration.geometry.units;
  if (!(geometry_.focal > 0.0) || !std::isfinite(geometry_.focal))
    throw RuntimeError("calibration '" + calibration.source + "': the rectified focal length P1(0,0) = " +
                       fixed(geometry_.focal, 3) + " is not positive");
  if (std::abs(P2.at<double>(1, 3)) > std::abs(P2.at<double>(0, 3)))
    throw RuntimeError("calibration '" + calibration.source +
                       "': the cameras are one above the other (vertical rectification); matching needs them side by "
                       "side: rotate both images by 90 degrees and calibrate again");
  if (!(geometry_.baseline > 0.0))
    throw RuntimeError("calibration '" + calibration.source + "': the baseline -P2(0,3) / P2(0,0) = " +
                       fixed(geometry_.baseline, 6) +
                       " is not positive: the right camera is not right of the left one (swapped images?)");

  // Fixed-point maps (CV_16SC2 positions with CV_16UC1 interpolation weights) remap about twice as
  // fast as float maps, at 1/32 px resolution.
  cv::initUndistortRectifyMap(K1, D1, R1, P1, size, CV_16SC2, left_x_, left_y_);
  cv::initUndistortRectifyMap(K2, D2, R2, P2, size, CV_16SC2, right_x_, right_y_);
}

void Rectifier::rectify(const cv::Mat& left, const cv::Mat& right, cv::Mat& left_out, cv::Mat& right_out) const {
  if (left.size() != left_x_.size() || right.size() != right_x_.size())
    throw RuntimeError("cannot rectify a " + size_text(left.cols, left.rows) + " / " +
                       size_text(right.cols, right.rows) + " pair with maps made for " +
                       size_text(left_x_.cols, left_x_.rows));
  // remap reallocates an output only when its size or type changes: reused outputs cost nothing.
  cv::remap(left, left_out, left_x_, left_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::remap(right, right_out, right_x_, right_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
}

// ORB finds no feature within 31 pixels (its edge threshold and patch) of a border, and shrinks
// the image over 8 levels: a smaller picture has none to match, and OpenCV fails on it.
constexpr int kMinCheckedSide = 64;

RectificationReport check_rectification(const cv::Mat& left, const cv::Mat& right) {
  for (const cv::Mat* view : {&left, &right})
    if (view->cols < kMinCheckedSide || view->rows < kMinCheckedSide)
      throw RuntimeError("the pair is " + size_text(view->cols, view->rows) +
                         ": too small to check its rectification (matching features needs at least " +
                         std::to_string(kMinCheckedSide) + " x " + std::to_string(kMinCheckedSide) + " pixels)");
  const cv::Mat left_gray = gray_of(left, "left"), right_gray = gray_of(right, "right");

  cv::Ptr<cv::ORB> orb = cv::ORB::create(3000);
  std::vector<cv::KeyPoint> left_points, right_points;
  cv::Mat left_descriptors, right_descriptors;
  orb->detectAndCompute(left_gray, cv::noArray(), left_points, left_descriptors);
  orb->detectAndCompute(right_gray, cv::noArray(), right_points, right_descriptors);
  RectificationReport report;
  report.features_left = static_cast<int>(left_points.size());
  report.features_right = static_cast<int>(right_points.size());

  // Mutual best matches that also pass Lowe's ratio test: a repeated texture matches several
  // places about as well, and such matches say nothing about rows.
  struct Match {
    double dx, dy;
  };
  std::vector<Match> matches;
  if (!left_descriptors.empty() && !right_descriptors.empty() && right_points.size() >= 2) {
    cv::BFMatcher matcher(cv::NORM_HAMMING);
    std::vector<std::vector<cv::DMatch>> forward;
    std::vector<cv::DMatch> backward;
    matcher.knnMatch(left_descriptors, right_descriptors, forward, 2);
    matcher.match(right_descriptors, left_descriptors, backward);
    const double max_dx = 0.5 * left_gray.cols, max_dy = 0.25 * left_gray.rows;
    for (const std::vector<cv::DMatch>& candidates : forward) {
      if (candidates.size() < 2) continue;
      const cv::DMatch& best = candidates[0];
      // Unrelated ORB descriptors differ in about half of their 256 bits; true matches in far fewer.
      if (best.distance > 64.0f || best.distance > 0.8f * candidates[1].distance) continue;
      if (backward[best.trainIdx].trainIdx != best.queryIdx) continue;
      const cv::Point2f pl = left_points[best.queryIdx].pt, pr = right_points[best.trainIdx].pt;
      const cv::Point il(cvRound(pl.x), cvRound(pl.y));
      cv::Point2d position(pr.x, pr.y);
      cv::Point2d refined;
      if (refine_match(left_gray, right_gray, il, cv::Point(cvRound(pr.x), cvRound(pr.y)), refined)) {
        position = refined;
      } else {
        position += cv::Point2d(il.x - pl.x, il.y - pl.y);
      }
      const double dx = il.x - position.x, dy = position.y - il.y;
      // Disparities of either sign (a pair may be swapped), within a broad plausible range.
      if (std::abs(dx) <= max_dx && std::abs(dy) <= max_dy) matches.push_back({dx, dy});
    }
  }

  // Mismatches that survived the tests are far from the bulk of the offsets: drop those beyond 5
  // robust standard deviations (1.4826 MAD) of the median, but never closer than 2 px, so that a
  // pair whose offsets vary over the image (a rotation) keeps them all.
  std::vector<double> dys;
  for (const Match& m : matches) dys.push_back(m.dy);
  const double centre = median(dys);
  std::vector<double> deviations;
  for (double dy : dys) deviations.push_back(std::abs(dy - centre));
  const double limit = std::max(5.0 * 1.4826 * median(deviations), 2.0);
  std::vector<double> kept_dy, abs_dy, dxs;
  for (const Match& m : matches) {
    if (std::abs(m.dy - centre) > limit) {
      ++report.outliers;
      continue;
    }
    kept_dy.push_back(m.dy);
    abs_dy.push_back(std::abs(m.dy));
    dxs.push_back(m.dx);
    if (m.dx < 0.0) ++report.negative_disparities;
  }
  report.matches = static_cast<int>(kept_dy.size());
  if (report.matches < 8) {
    const bool few_features = std::min(report.features_left, report.features_right) < 50;
    throw RuntimeError("only " + std::to_string(report.matches) + " features match between the views (" +
                       std::to_string(report.features_left) + " found in the left, " +
                       std::to_string(report.features_right) + " in the right), too few to measure the rows: " +
                       (std::min(left_gray.cols, left_gray.rows) < 64 ? "the images are too small"
                        : few_features ? "the images look textureless (blank, blurred or very dark)"
                                       : "the views may show different scenes, or differ too much in scale or exposure"));
  }
  report.median_dy = median(kept_dy);
  report.median_abs_dy = median(abs_dy);
  report.p95_abs_dy = percentile(abs_dy, 95.0);
  report.max_abs_dy = *std::max_element(abs_dy.begin(), abs_dy.end());
  report.median_dx = median(dxs);

  const std::string measured = " (median |dy| " + fixed(report.median_abs_dy, 2) + " px)";
  if (report.median_abs_dy <= 0.5)
    report.verdict = "rectified" + measured + ": matching points lie on the same rows";
  else if (report.median_abs_dy <= 1.5)
    report.verdict = "slightly off" + measured +
                     ": matching along rows still works, but expect more invalid pixels and noise; "
                     "a better calibration or rectification would help";
  else
    report.verdict = "not rectified" + measured +
                     ": matching along rows will fail; calibrate the rig and rectify the pair first";
  if (2 * report.negative_disparities > report.matches)
    report.verdict += "; most disparities are negative: are left and right swapped?";
  return report;
}

}  // namespace mctstereo::app
