// Depth files (PFM, 16-bit PNG of millimetres) encoded and decoded, and `mctstereo match` with a
// calibration: depth maps and point clouds of the Tsukuba pair read back and checked against the
// disparity file written beside them, and the mistakes that must write nothing.
#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "depth_files.hpp"
#include "errors.hpp"

#include "cli_test_util.hpp"

namespace {

using mctstereo::test::kData;
using mctstereo::test::folder_listing;
using mctstereo::test::kProgram;
using mctstereo::test::read_text;
using mctstereo::test::Result;
using mctstereo::test::run_shell;
using mctstereo::test::shell_quoted;

namespace fs = std::filesystem;

constexpr int kWidth = 384, kHeight = 288;

// A float map (PFM, CV_32FC1) read by OpenCV, rows top to bottom.
cv::Mat read_float_map(const fs::path& path) {
  const cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(m.type(), CV_32FC1) << path;
  EXPECT_EQ(m.size(), cv::Size(kWidth, kHeight)) << path;
  return m;
}

struct Cloud {
  std::vector<std::string> comments;
  std::vector<float> xyz;
  std::vector<std::uint8_t> rgb;
  std::size_t size() const { return xyz.size() / 3; }
};

// A binary little-endian PLY of float x y z and uchar red green blue.
Cloud read_ply(const fs::path& path) {
  const std::string bytes = read_text(path);
  Cloud cloud;
  std::size_t at = 0, vertices = 0;
  std::vector<std::string> properties;
  for (std::string line; line != "end_header";) {
    const std::size_t end = bytes.find('\n', at);
    if (end == std::string::npos) {
      ADD_FAILURE() << path << ": no end_header";
      return cloud;
    }
    line = bytes.substr(at, end - at);
    at = end + 1;
    if (line.rfind("comment ", 0) == 0) cloud.comments.push_back(line.substr(8));
    if (line.rfind("element vertex ", 0) == 0) vertices = std::stoul(line.substr(15));
    if (line.rfind("property ", 0) == 0) properties.push_back(line.substr(9));
  }
  EXPECT_EQ(bytes.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  const std::vector<std::string> expected = {"float x",     "float y",       "float z",
                                             "uchar red",   "uchar green",   "uchar blue"};
  EXPECT_EQ(properties, expected);
  if (bytes.size() - at != vertices * 15) {
    ADD_FAILURE() << path << ": " << bytes.size() - at << " bytes for " << vertices << " vertices";
    return cloud;
  }
  for (std::size_t i = 0; i < vertices; ++i) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data() + at + 15 * i);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t bits = p[4 * k] | p[4 * k + 1] << 8 | p[4 * k + 2] << 16 | std::uint32_t(p[4 * k + 3]) << 24;
      float v;
      std::memcpy(&v, &bits, 4);
      cloud.xyz.push_back(v);
    }
    for (int k = 12; k < 15; ++k) cloud.rgb.push_back(p[k]);
  }
  return cloud;
}

// A Wavefront OBJ of "v x y z r g b" lines and "#" comments.
Cloud read_obj(const fs::path& path) {
  std::istringstream lines(read_text(path));
  Cloud cloud;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# ", 0) == 0) {
      cloud.comments.push_back(line.substr(2));
      continue;
    }
    std::istringstream words(line);
    std::string v;
    float x, y, z, r, g, b;
    if (!(words >> v >> x >> y >> z >> r >> g >> b) || v != "v") {
      ADD_FAILURE() << path << ": not a vertex line: " << line;
      return cloud;
    }
    cloud.xyz.insert(cloud.xyz.end(), {x, y, z});
    for (float c : {r, g, b}) cloud.rgb.push_back(static_cast<std::uint8_t>(std::lround(c * 255.0f)));
  }
  return cloud;
}

// The geometry the tests give: f = 400 px, B = 0.16 m (or 160 mm), principal point (190, 140),
// doffs 1.5 px so that d = 0 still has a depth.
constexpr double kFocal = 400.0, kBaseline = 0.16, kCx = 190.0, kCy = 140.0, kDoffs = 1.5;
const std::string kGeometryFlags = "--focal 400 --baseline 0.16 --cx 190 --cy 140 --doffs 1.5";

// The same as a Middlebury calib.txt, in millimetres, for images of width x height.
std::string calib_txt(int width, int height) {
  return "cam0=[400 0 190; 0 400 140; 0 0 1]\ncam1=[400 0 191.5; 0 400 140; 0 0 1]\ndoffs=1.5\nbaseline=160\n"
         "width=" + std::to_string(width) + "\nheight=" + std::to_string(height) + "\nndisp=16\n";
}

TEST(DepthFiles, PngHoldsRoundedMillimetresAndZeroWhereNone) {
  using namespace mctstereo;
  using namespace mctstereo::app;
  // Metres: 1.2344 m, 65.535 m (the largest), 65.536 m (beyond), none, 0.0004 m (under 0.5 mm).
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<float> depth = {1.2344f, 65.535f, 65.536f, nan, 0.0004f, inf, 2.0f, 0.0f};
  const MapView<const float> map{depth.data(), 4, 2, 4};
  const std::vector<std::uint8_t> png = encode_depth(map, "m", DepthFormat::PngMillimetres);
  const cv::Mat decoded = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(decoded.type(), CV_16UC1);
  ASSERT_EQ(decoded.size(), cv::Size(4, 2));
  const std::uint16_t expected[2][4] = {{1234, 65535, 0, 0}, {1, 0, 2000, 0}};
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(decoded.at<std::uint16_t>(y, x), expected[y][x]) << x << "," << y;
  // Other units are converted to millimetres.
  const cv::Mat inches = cv::imdecode(encode_depth(map, "in", DepthFormat::PngMillimetres), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(inches.at<std::uint16_t>(1, 2), 51);  // 2 in = 50.8 mm
  EXPECT_EQ(millimetres_per_unit("CM"), 10.0);
  EXPECT_EQ(millimetres_per_unit("ft"), 304.8);
  EXPECT_THROW(millimetres_per_unit("furlong"), UsageError);
  EXPECT_THROW(encode_depth(map, "", DepthFormat::PngMillimetres), UsageError);  // relative depth

  // PFM: the values as they are, +INF where none.
  const cv::Mat pfm = cv::imdecode(encode_depth(map, "", DepthFormat::Pfm), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(pfm.type(), CV_32FC1);
  EXPECT_EQ(pfm.at<float>(0, 0), 1.2344f);
  EXPECT_EQ(pfm.at<float>(0, 3), inf);
  EXPECT_EQ(pfm.at<float>(1, 1), inf);
  EXPECT_EQ(pfm.at<float>(1, 2), 2.0f);

  EXPECT_EQ(depth_format_for("a/b.PFM"), DepthFormat::Pfm);
  EXPECT_EQ(depth_format_for("z.png"), DepthFormat::PngMillimetres);
  EXPECT_THROW(depth_format_for("z.tif"), UsageError);
}

class DepthCli : public mctstereo::test::FolderTest {
 protected:
  void SetUp() override {
    FolderTest::SetUp();
    copy_tsukuba_pair();
  }
};

// Few disparities and no filling: quick, and with invalid pixels the clouds must leave out.
// --fill none and no weighted median (which would give the holes their neighbours' value).
const std::string kPair = "match left.png right.png --num-disparities 16 --fill none --weighted-median off ";

TEST_F(DepthCli, FlagsGiveDepthAndCloudsOfTheDisparityFile) {
  const Result r = run(kPair + "-o d.pfm --depth z.pfm --ply c.ply --obj c.obj " + kGeometryFlags);
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  for (const char* part : {"z.pfm (depth PFM, m", "c.ply (PLY, ", "c.obj (OBJ, "})
    EXPECT_NE(r.output.find(part), std::string::npos) << part << " missing in: " << r.output;

  const cv::Mat d = read_float_map(folder_ / "d.pfm");
  const cv::Mat z = read_float_map(folder_ / "z.pfm");
  const Cloud ply = read_ply(folder_ / "c.ply");
  const Cloud obj = read_obj(folder_ / "c.obj");
  const cv::Mat left = cv::imread((folder_ / "left.png").string(), cv::IMREAD_COLOR);
  ASSERT_EQ(d.size(), cv::Size(kWidth, kHeight));
  ASSERT_EQ(z.size(), cv::Size(kWidth, kHeight));
  const int valid = cv::countNonZero(d != std::numeric_limits<float>::infinity());
  ASSERT_GT(valid, kWidth * kHeight / 2);
  ASSERT_LT(valid, kWidth * kHeight);  // --fill none leaves invalid pixels to skip
  ASSERT_EQ(ply.size(), static_cast<std::size_t>(valid));
  ASSERT_EQ(obj.size(), static_cast<std::size_t>(valid));
  EXPECT_EQ(obj.rgb, ply.rgb);
  EXPECT_NE(r.output.find(std::to_string(valid) + " points"), std::string::npos) << r.output;

  // Points are in row order of the valid pixels: Z = f B / (d + doffs), X, Y from the pixel.
  std::size_t i = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const float disparity = d.at<float>(y, x);
      if (std::isinf(disparity)) {
        ASSERT_TRUE(std::isinf(z.at<float>(y, x))) << x << "," << y;
        continue;
      }
      const double depth = kFocal * kBaseline / (disparity + kDoffs);
      ASSERT_FLOAT_EQ(z.at<float>(y, x), static_cast<float>(depth)) << x << "," << y;
      ASSERT_FLOAT_EQ(ply.xyz[3 * i + 2], static_cast<float>(depth)) << x << "," << y;
      ASSERT_FLOAT_EQ(ply.xyz[3 * i + 0], static_cast<float>((x - kCx) * depth / kFocal)) << x << "," << y;
      ASSERT_FLOAT_EQ(ply.xyz[3 * i + 1], static_cast<float>((y - kCy) * depth / kFocal)) << x << "," << y;
      for (int k = 0; k < 3; ++k) ASSERT_EQ(obj.xyz[3 * i + k], ply.xyz[3 * i + k]) << x << "," << y;
      const cv::Vec3b bgr = left.at<cv::Vec3b>(y, x);
      ASSERT_EQ(ply.rgb[3 * i + 0], bgr[2]) << x << "," << y;
      ASSERT_EQ(ply.rgb[3 * i + 1], bgr[1]) << x << "," << y;
      ASSERT_EQ(ply.rgb[3 * i + 2], bgr[0]) << x << "," << y;
      ++i;
    }

  // The header says what the numbers are.
  for (const Cloud* cloud : {&ply, &obj}) {
    const std::string all = [&] {
      std::string text;
      for (const std::string& c : cloud->comments) text += c + "\n";
      return text;
    }();
    for (const char* part : {"units m", "frame left rectified camera: X right, Y down, Z forward", "focal 400 px",
                             "baseline 0.16 m", "doffs 1.5 px", "left left.png", "right right.png"})
      EXPECT_NE(all.find(part), std::string::npos) << part << " missing in:\n" << all;
  }
}

TEST_F(DepthCli, CalibTxtGivesMillimetresAndMaxDepthDropsPoints) {
  write("calib.txt", calib_txt(kWidth, kHeight));
  // 16-bit PNG of millimetres, and depth and cloud cut at 6 m: d < 9.17 is background.
  const Result r = run(kPair + "-o d.pfm --calib calib.txt --depth z.png --ply near.ply --max-depth 6000");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("z.png (depth 16-bit PNG, mm"), std::string::npos) << r.output;
  const cv::Mat d = read_float_map(folder_ / "d.pfm");
  const cv::Mat z = cv::imread((folder_ / "z.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(z.type(), CV_16UC1);
  ASSERT_EQ(z.size(), cv::Size(kWidth, kHeight));
  const Cloud near = read_ply(folder_ / "near.ply");
  std::size_t kept = 0, dropped = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const float disparity = d.at<float>(y, x);
      if (std::isinf(disparity)) {
        ASSERT_EQ(z.at<std::uint16_t>(y, x), 0) << x << "," << y;
        continue;
      }
      const double mm = 400.0 * 160.0 / (disparity + 1.5);
      if (mm > 6000.0) {
        ++dropped;
        ASSERT_EQ(z.at<std::uint16_t>(y, x), 0) << x << "," << y;
        continue;
      }
      // The depth map holds float depths, rounded to millimetres.
      ASSERT_EQ(z.at<std::uint16_t>(y, x), std::lround(static_cast<float>(mm))) << x << "," << y;
      ASSERT_FLOAT_EQ(near.xyz[3 * kept + 2], static_cast<float>(mm)) << x << "," << y;
      ++kept;
    }
  EXPECT_GT(dropped, 1000u);
  EXPECT_GT(kept, 1000u);
  EXPECT_EQ(near.size(), kept);
  EXPECT_NE(std::find(near.comments.begin(), near.comments.end(), "units mm"), near.comments.end());
}

TEST_F(DepthCli, WithoutCalibrationDepthIsRelative) {
  const Result r = run(kPair + "-o d.pfm --depth r.pfm");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("note: no calibration"), std::string::npos) << r.output;
  const cv::Mat d = read_float_map(folder_ / "d.pfm");
  const cv::Mat rel = read_float_map(folder_ / "r.pfm");
  int positive = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const float disparity = d.at<float>(y, x);
      if (std::isfinite(disparity) && disparity > 0) {
        ++positive;
        ASSERT_FLOAT_EQ(rel.at<float>(y, x), 1.0f / disparity) << x << "," << y;
      } else {
        ASSERT_TRUE(std::isinf(rel.at<float>(y, x))) << x << "," << y;
      }
    }
  EXPECT_GT(positive, kWidth * kHeight / 2);
}

constexpr int kUsage = 2;
constexpr int kRuntime = 1;

TEST_F(DepthCli, BadCalibrationsAndMissingFlagsWriteNothing) {
  write("big.txt", calib_txt(2 * kWidth, 2 * kHeight));
  expect_failure(kPair + "-o d.pfm --calib big.txt --ply c.ply", kRuntime, "is for 768x576 images but");
  expect_failure(kPair + "-o d.pfm --calib big.txt --ply c.ply", kRuntime, "384x288");
  write("nobaseline.txt", "cam0=[400 0 190; 0 400 140; 0 0 1]\ndoffs=1.5\n");
  expect_failure(kPair + "-o d.pfm --calib nobaseline.txt --depth z.pfm", kRuntime, "key 'baseline' is missing");
  expect_failure(kPair + "-o d.pfm --calib none.txt --depth z.pfm", kRuntime, "'none.txt': no such file");
  write("p1.yml", "%YAML:1.0\nP2: !!opencv-matrix\n  rows: 3\n  cols: 4\n  dt: d\n"
                  "  data: [400, 0, 191.5, -64, 0, 400, 140, 0, 0, 0, 1, 0]\n");
  expect_failure(kPair + "-o d.pfm --calib p1.yml --ply c.ply", kRuntime, "key 'P1' is missing");
  write("rig.yml", "%YAML:1.0\nimage_width: 384\nimage_height: 288\n"
                   "K1: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [400, 0, 190, 0, 400, 140, 0, 0, 1]\n"
                   "D1: !!opencv-matrix\n  rows: 1\n  cols: 5\n  dt: d\n  data: [0, 0, 0, 0, 0]\n"
                   "K2: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [400, 0, 190, 0, 400, 140, 0, 0, 1]\n"
                   "D2: !!opencv-matrix\n  rows: 1\n  cols: 5\n  dt: d\n  data: [0, 0, 0, 0, 0]\n"
                   "R: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
                   "T: !!opencv-matrix\n  rows: 3\n  cols: 1\n  dt: d\n  data: [0.16, 0, 0]\n");
  // The right camera 0.16 to the left of the left one: a swapped pair, which no rectification mends.
  expect_failure(kPair + "-o d.pfm --calib rig.yml --ply c.ply", kRuntime, "swapped");

  expect_failure(kPair + "-o d.pfm --ply c.ply", kUsage, "--ply 'c.ply': a point cloud needs a calibration");
  expect_failure(kPair + "-o d.pfm --obj c.obj", kUsage, "--obj 'c.obj': a point cloud needs a calibration");
  expect_failure(kPair + "-o d.pfm --depth z.png", kUsage, "needs a calibration");
  expect_failure(kPair + "-o d.pfm --ply c.ply --focal 400", kUsage, "--baseline is missing");
  expect_failure(kPair + "-o d.pfm --depth z.pfm --max-depth 5", kUsage, "--max-depth");
  expect_failure(kPair + "-o d.pfm --max-depth 5 " + kGeometryFlags, kUsage, "--max-depth");
  expect_failure(kPair + "-o d.pfm --depth z.tif " + kGeometryFlags, kUsage, "'z.tif'");
  expect_failure(kPair + "-o d.pfm --depth z.png " + kGeometryFlags + " --units furlong", kUsage, "furlong");
  expect_failure(kPair + "-o d.pfm --depth left.png " + kGeometryFlags, kUsage, "refusing to overwrite an input");
  write("calib.txt", calib_txt(kWidth, kHeight));
  expect_failure(kPair + "-o d.pfm --calib calib.txt --ply calib.txt", kUsage, "refusing to overwrite an input");
  expect_failure(kPair + "-o d.pfm --ply d.pfm " + kGeometryFlags, kUsage, "the same file");
  expect_failure(kPair + "-o d.pfm --ply nofolder/c.ply " + kGeometryFlags, kRuntime, "'nofolder' does not exist");
}

}  // namespace
