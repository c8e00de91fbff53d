// Rectification of a synthetic rig with a known geometry, and the rectification check on
// rectified, shifted, rotated and blank pairs.
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <unistd.h>

#include "calibration.hpp"
#include "errors.hpp"

#include "cli_test_util.hpp"

namespace {

using mctstereo::app::Calibration;
using mctstereo::app::check_rectification;
using mctstereo::app::RectificationReport;
using mctstereo::app::Rectifier;
using mctstereo::app::RuntimeError;
using mctstereo::test::kData;

constexpr int kWidth = 480, kHeight = 360;
constexpr double kFocal = 400.0, kCx = 241.5, kCy = 178.0;
constexpr double kPlaneDepth = 2.0;  // metres, the plane Z = kPlaneDepth of the left camera
constexpr double kTexel = 0.004;     // metres per texture pixel: about 0.8 image pixels at the plane

// A rig with a known geometry: both cameras with the same intrinsics and a little distortion, the
// right camera 0.1 m to the right (and a few mm off), turned by a few degrees.
Calibration synthetic_rig() {
  Calibration c;
  c.width = kWidth;
  c.height = kHeight;
  c.needs_rectification = true;
  c.source = "synthetic rig";
  c.K1 = (cv::Mat_<double>(3, 3) << kFocal, 0, kCx, 0, kFocal, kCy, 0, 0, 1);
  c.K2 = c.K1.clone();
  c.D1 = (cv::Mat_<double>(1, 5) << -0.05, 0.01, 0, 0, 0);
  c.D2 = (cv::Mat_<double>(1, 5) << -0.04, 0.008, 0, 0, 0);
  // X_right = R X_left + T: a rotation of about 1.1 to 1.7 degrees about each axis.
  const cv::Mat rotation_vector = (cv::Mat_<double>(3, 1) << 0.02, -0.03, 0.025);
  cv::Rodrigues(rotation_vector, c.R);
  const cv::Mat right_centre = (cv::Mat_<double>(3, 1) << 0.1, 0.003, -0.002);  // in the left camera's frame
  c.T = -c.R * right_centre;
  return c;
}

// A random texture of 4 x 4 texel blocks, slightly blurred: corners for the detector, and smooth
// enough to sample at any scale near 1.
cv::Mat plane_texture() {
  cv::RNG rng(20261123);
  cv::Mat blocks(260, 330, CV_8UC1);
  rng.fill(blocks, cv::RNG::UNIFORM, 0, 256);
  cv::Mat texture;
  cv::resize(blocks, texture, cv::Size(), 4, 4, cv::INTER_NEAREST);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.0);
  return texture;
}

// The plane Z = kPlaneDepth (left camera frame) seen by a camera with intrinsics K, distortion D
// and pose X_camera = R X_left + T, by inverse mapping: the ray of each pixel meets the plane at a
// point whose texture is sampled.
cv::Mat render_plane(const cv::Mat& texture, const cv::Mat& K, const cv::Mat& D, const cv::Mat& R, const cv::Mat& T) {
  std::vector<cv::Point2f> pixels;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) pixels.emplace_back(static_cast<float>(x), static_cast<float>(y));
  std::vector<cv::Point2f> normalised;
  cv::undistortPoints(pixels, normalised, K, D, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-10));
  const cv::Matx33d Rt = cv::Matx33d(R).t();
  const cv::Vec3d centre = -(Rt * cv::Vec3d(T));  // the camera's centre in the left frame
  cv::Mat map_x(kHeight, kWidth, CV_32FC1), map_y(kHeight, kWidth, CV_32FC1);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const cv::Point2f n = normalised[static_cast<std::size_t>(y) * kWidth + x];
      const cv::Vec3d direction = Rt * cv::Vec3d(n.x, n.y, 1.0);
      const double t = (kPlaneDepth - centre[2]) / direction[2];
      const cv::Vec3d point = centre + t * direction;
      map_x.at<float>(y, x) = static_cast<float>(point[0] / kTexel + 0.5 * texture.cols);
      map_y.at<float>(y, x) = static_cast<float>(point[1] / kTexel + 0.5 * texture.rows);
    }
  cv::Mat image;
  cv::remap(texture, image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return image;
}

struct SyntheticPair {
  Calibration rig = synthetic_rig();
  cv::Mat left, right;
  SyntheticPair() {
    const cv::Mat texture = plane_texture();
    left = render_plane(texture, rig.K1, rig.D1, cv::Mat::eye(3, 3, CV_64F), cv::Mat::zeros(3, 1, CV_64F));
    right = render_plane(texture, rig.K2, rig.D2, rig.R, rig.T);
  }
};

const SyntheticPair& synthetic_pair() {
  static const SyntheticPair pair;
  return pair;
}

// The disparity of the plane at the rectified left pixel (u, v): its ray, turned back into the
// left camera's frame by R1^T, meets the plane at a depth Z' along the rectified optical axis.
double expected_disparity(const Rectifier& rectifier, const cv::Mat& R1, double u, double v) {
  const auto& g = rectifier.geometry();
  const cv::Vec3d ray((u - g.cx) / g.focal, (v - g.cy) / g.focal, 1.0);
  const cv::Vec3d in_left = cv::Matx33d(R1).t() * ray;
  const double rectified_depth = kPlaneDepth / in_left[2];
  return g.focal * g.baseline / rectified_depth - g.doffs;
}

// The disparity at the left pixel (u, v) by block matching along the row: normalised cross-
// correlation of a 21 x 21 patch and a parabola through the peak.
double measured_disparity(const cv::Mat& left, const cv::Mat& right, int u, int v, double guess) {
  constexpr int kHalf = 10, kReach = 8;
  const cv::Mat patch = left(cv::Rect(u - kHalf, v - kHalf, 2 * kHalf + 1, 2 * kHalf + 1));
  const int x0 = static_cast<int>(std::lround(u - guess)) - kReach - kHalf;
  const cv::Mat strip = right(cv::Rect(x0, v - kHalf, 2 * (kHalf + kReach) + 1, 2 * kHalf + 1));
  cv::Mat score;
  cv::matchTemplate(strip, patch, score, cv::TM_CCOEFF_NORMED);
  cv::Point at;
  cv::minMaxLoc(score, nullptr, nullptr, nullptr, &at);
  if (at.x == 0 || at.x == score.cols - 1) return -1e9;
  const double a = score.at<float>(0, at.x - 1), b = score.at<float>(0, at.x), c = score.at<float>(0, at.x + 1);
  const double offset = 0.5 * (a - c) / (a - 2 * b + c);
  return u - (x0 + kHalf + at.x + offset);
}

TEST(Rectification, SyntheticRigIsRectifiedToTheKnownGeometry) {
  const SyntheticPair& pair = synthetic_pair();

  const RectificationReport raw = check_rectification(pair.left, pair.right);
  EXPECT_GT(raw.median_abs_dy, 2.0) << raw.verdict;
  EXPECT_EQ(raw.verdict.rfind("not rectified", 0), 0u) << raw.verdict;

  const Rectifier rectifier(pair.rig, kWidth, kHeight);
  cv::Mat left, right;
  rectifier.rectify(pair.left, pair.right, left, right);
  ASSERT_EQ(left.size(), cv::Size(kWidth, kHeight));
  ASSERT_EQ(right.size(), cv::Size(kWidth, kHeight));

  const RectificationReport rectified = check_rectification(left, right);
  EXPECT_GE(rectified.matches, 100);
  EXPECT_LT(rectified.median_abs_dy, 0.1) << rectified.verdict;
  EXPECT_LT(rectified.p95_abs_dy, 0.3);
  EXPECT_LT(std::abs(rectified.median_dy), 0.05);
  EXPECT_EQ(rectified.verdict.rfind("rectified", 0), 0u) << rectified.verdict;
  EXPECT_EQ(rectified.negative_disparities, 0);

  // The rectified geometry: stereoRectify keeps the baseline's length, zero disparity at infinity.
  const auto& g = rectifier.geometry();
  EXPECT_NEAR(g.baseline, std::sqrt(0.1 * 0.1 + 0.003 * 0.003 + 0.002 * 0.002), 1e-9);
  EXPECT_NEAR(g.doffs, 0.0, 1e-9);
  EXPECT_EQ(g.units, "m");
  EXPECT_GT(g.focal, 0.8 * kFocal);
  EXPECT_LT(g.focal, 1.5 * kFocal);

  // The plane's disparity where it is measured: f' B / Z' (Z' along the rectified axis), about 22 px.
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(pair.rig.K1, pair.rig.D1, pair.rig.K2, pair.rig.D2, cv::Size(kWidth, kHeight), pair.rig.R,
                    pair.rig.T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0);
  EXPECT_NEAR(rectified.median_dx, expected_disparity(rectifier, R1, kWidth / 2.0, kHeight / 2.0), 0.3);
  for (const cv::Point p : {cv::Point(120, 90), cv::Point(240, 180), cv::Point(360, 90), cv::Point(150, 270),
                            cv::Point(330, 270)}) {
    const double expected = expected_disparity(rectifier, R1, p.x, p.y);
    EXPECT_GT(expected, 15.0);
    EXPECT_NEAR(measured_disparity(left, right, p.x, p.y, expected), expected, 0.1) << "at " << p;
  }
}

TEST(Rectification, UsesTheCalibrationsRectifyingTransforms) {
  Calibration rig = synthetic_rig();
  cv::Mat Q;
  // alpha 1 keeps every source pixel: another focal length and principal point than alpha 0.
  cv::stereoRectify(rig.K1, rig.D1, rig.K2, rig.D2, cv::Size(kWidth, kHeight), rig.R, rig.T, rig.R1, rig.R2, rig.P1,
                    rig.P2, Q, cv::CALIB_ZERO_DISPARITY, 1.0);
  rig.P2.at<double>(0, 2) += 3.0;  // a principal point 3 px further right in the right view: doffs 3
  rig.geometry.units = "mm";
  const Rectifier rectifier(rig, kWidth, kHeight);
  const auto& g = rectifier.geometry();
  EXPECT_DOUBLE_EQ(g.focal, rig.P1.at<double>(0, 0));
  EXPECT_DOUBLE_EQ(g.cx, rig.P1.at<double>(0, 2));
  EXPECT_DOUBLE_EQ(g.cy, rig.P1.at<double>(1, 2));
  EXPECT_DOUBLE_EQ(g.baseline, -rig.P2.at<double>(0, 3) / rig.P2.at<double>(0, 0));
  EXPECT_NEAR(g.doffs, 3.0, 1e-9);
  EXPECT_EQ(g.units, "mm");
}

TEST(Rectification, CalibrationForAnotherSizeIsRefused) {
  const Calibration rig = synthetic_rig();
  try {
    Rectifier rectifier(rig, 640, 480);
    FAIL() << "a 480x360 calibration rectified 640x480 images";
  } catch (const RuntimeError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("480x360"), std::string::npos) << message;
    EXPECT_NE(message.find("640x480"), std::string::npos) << message;
    EXPECT_NE(message.find("synthetic rig"), std::string::npos) << message;
  }
  // A rectified pair's calibration (no K1, K2) has nothing to rectify with.
  Calibration rectified;
  rectified.source = "calib.txt";
  EXPECT_THROW(Rectifier(rectified, kWidth, kHeight), RuntimeError);
}

TEST(Rectification, WrongSizeFramesAreRefused) {
  const Rectifier rectifier(synthetic_rig(), kWidth, kHeight);
  const cv::Mat small(100, 100, CV_8UC1, cv::Scalar(0));
  cv::Mat left, right;
  EXPECT_THROW(rectifier.rectify(small, small, left, right), RuntimeError);
}

TEST(Rectification, RectifyingReusesTheOutputs) {
  const SyntheticPair& pair = synthetic_pair();
  const Rectifier rectifier(pair.rig, kWidth, kHeight);
  cv::Mat left, right;
  rectifier.rectify(pair.left, pair.right, left, right);
  const uchar* left_data = left.data;
  const uchar* right_data = right.data;
  const cv::Mat first = left.clone();
  rectifier.rectify(pair.left, pair.right, left, right);
  EXPECT_EQ(left.data, left_data);
  EXPECT_EQ(right.data, right_data);
  EXPECT_EQ(cv::norm(left, first, cv::NORM_INF), 0.0);
}

cv::Mat read_tsukuba(const char* name) {
  const cv::Mat image = cv::imread((kData / "tsukuba" / name).string(), cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty()) << "cannot read " << (kData / "tsukuba" / name);
  return image;
}

TEST(RectificationCheck, TsukubaIsRectified) {
  const cv::Mat left = read_tsukuba("imL.png"), right = read_tsukuba("imR.png");
  ASSERT_FALSE(left.empty() || right.empty());
  const RectificationReport report = check_rectification(left, right);
  EXPECT_GE(report.matches, 50);
  EXPECT_LE(report.median_abs_dy, 0.25);
  EXPECT_LE(report.p95_abs_dy, 1.5);
  EXPECT_EQ(report.verdict.rfind("rectified", 0), 0u) << report.verdict;
  // Tsukuba's disparities lie in 5 .. 14 px.
  EXPECT_GE(report.median_dx, 4.0);
  EXPECT_LE(report.median_dx, 15.0);
  EXPECT_LT(report.negative_disparities, report.matches / 20);
}

TEST(RectificationCheck, TsukubaShiftedByThreeRowsIsNotRectified) {
  const cv::Mat left = read_tsukuba("imL.png"), right = read_tsukuba("imR.png");
  ASSERT_FALSE(left.empty() || right.empty());
  cv::Mat shifted;
  const cv::Mat down_by_3 = (cv::Mat_<double>(2, 3) << 1, 0, 0, 0, 1, 3);
  cv::warpAffine(right, shifted, down_by_3, right.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  const RectificationReport report = check_rectification(left, shifted);
  EXPECT_GE(report.matches, 50);
  EXPECT_NEAR(report.median_dy, 3.0, 0.25);
  EXPECT_NEAR(report.median_abs_dy, 3.0, 0.25);
  EXPECT_EQ(report.verdict.rfind("not rectified", 0), 0u) << report.verdict;

  // One row only: slightly off.
  const cv::Mat down_by_1 = (cv::Mat_<double>(2, 3) << 1, 0, 0, 0, 1, 1);
  cv::warpAffine(right, shifted, down_by_1, right.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  const RectificationReport slightly = check_rectification(left, shifted);
  EXPECT_NEAR(slightly.median_abs_dy, 1.0, 0.25);
  EXPECT_EQ(slightly.verdict.rfind("slightly off", 0), 0u) << slightly.verdict;
}

TEST(RectificationCheck, SwappedViewsAreNamed) {
  const cv::Mat left = read_tsukuba("imL.png"), right = read_tsukuba("imR.png");
  ASSERT_FALSE(left.empty() || right.empty());
  const RectificationReport report = check_rectification(right, left);
  EXPECT_GT(report.negative_disparities, report.matches / 2);
  EXPECT_LE(report.median_dx, -4.0);
  EXPECT_NE(report.verdict.find("swapped"), std::string::npos) << report.verdict;
}

TEST(RectificationCheck, BlankImagesAreTooFewFeatures) {
  const cv::Mat blank(240, 320, CV_8UC1, cv::Scalar(128));
  try {
    check_rectification(blank, blank);
    FAIL() << "a blank pair was measured";
  } catch (const RuntimeError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("only 0 features match"), std::string::npos) << message;
    EXPECT_NE(message.find("textureless"), std::string::npos) << message;
  }
  // Two unrelated textures: features, but no consistent matches.
  cv::Mat a(240, 320, CV_8UC1), b(240, 320, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(a, cv::RNG::UNIFORM, 0, 256);
  rng.fill(b, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(a, a, cv::Size(0, 0), 1.5);
  cv::GaussianBlur(b, b, cv::Size(0, 0), 1.5);
  try {
    const RectificationReport report = check_rectification(a, b);
    ADD_FAILURE() << "unrelated images gave " << report.matches << " matches: " << report.verdict;
  } catch (const RuntimeError& e) {
    EXPECT_NE(std::string(e.what()).find("different scenes"), std::string::npos) << e.what();
  }
}

// The command line with a calibration of the raw rig: match rectifies the pair first, reports both
// pairs' rows, and its disparity and depth are those of the plane in the rectified frame.
TEST(RectificationCli, MatchRectifiesARawPairWithItsCalibration) {
  const SyntheticPair& pair = synthetic_pair();
  const std::filesystem::path folder =
      std::filesystem::temp_directory_path() / ("mctstereo_rectify_cli_" + std::to_string(::getpid()));
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  ASSERT_TRUE(cv::imwrite((folder / "left.png").string(), pair.left));
  ASSERT_TRUE(cv::imwrite((folder / "right.png").string(), pair.right));
  // As OpenCV's stereo calibration writes it: the raw cameras with their rectifying transforms.
  Calibration rig = pair.rig;
  cv::stereoRectify(rig.K1, rig.D1, rig.K2, rig.D2, cv::Size(kWidth, kHeight), rig.R, rig.T, rig.R1, rig.R2, rig.P1,
                    rig.P2, rig.Q, cv::CALIB_ZERO_DISPARITY, 0);
  const Rectifier rectifier(rig, kWidth, kHeight);
  rig.geometry = rectifier.geometry();
  mctstereo::app::write_calibration((folder / "rig.yml").string(), rig);

  const auto r = mctstereo::test::run_shell(
      "cd " + mctstereo::test::shell_quoted(folder.string()) + " && " +
      mctstereo::test::shell_quoted(mctstereo::test::kProgram.string()) +
      " match left.png right.png --calib rig.yml --num-disparities 48 --preset quality -o d.pfm --depth z.pfm "
      "--check-rectification 2>&1");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("rectification of the input pair"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("; not rectified"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("rectification of the rectified pair"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("; rectified (median |dy|"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("rectified with 'rig.yml'"), std::string::npos) << r.output;

  const cv::Mat& R1 = rig.R1;
  const cv::Mat d = cv::imread((folder / "d.pfm").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat z = cv::imread((folder / "z.pfm").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(d.type(), CV_32FC1);
  ASSERT_EQ(z.type(), CV_32FC1);
  // Points well inside the view: the map's disparity and depth are the plane's.
  int checked = 0;
  for (int v = 100; v <= 260; v += 40)
    for (int u = 140; u <= 340; u += 50) {
      const double expected = expected_disparity(rectifier, R1, u, v);
      const double depth = rectifier.geometry().depth(expected);
      EXPECT_NEAR(d.at<float>(v, u), expected, 0.5) << "at (" << u << ", " << v << ")";
      EXPECT_NEAR(z.at<float>(v, u), depth, 0.03 * depth) << "at (" << u << ", " << v << ")";
      ++checked;
    }
  EXPECT_EQ(checked, 25);
  std::filesystem::remove_all(folder);
}

}  // namespace
