// `mctstereo render`: a few coloured points drawn where the pinhole projection puts them, nearer
// points hiding farther ones, ascii and binary PLY alike, and bad files refused by name.
#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.hpp"

namespace {

using mctstereo::test::kProgram;
using mctstereo::test::Result;
using mctstereo::test::run_shell;
using mctstereo::test::shell_quoted;

namespace fs = std::filesystem;

struct Point {
  double x, y, z;
  std::uint8_t r, g, b;
};

// The centre of this cloud (the median of each coordinate) is (0, 0, 3): on the optical axis, so
// that the view with yaw 0 and pitch 0 is the original camera itself. With focal 100 and a 101x81
// picture (principal point (50, 40)) the points land on whole pixels.
const std::vector<Point> kCloud = {
    {0.0, 0.0, 2.0, 255, 0, 0},      // red, at (50, 40)
    {0.0, 0.0, 4.0, 0, 255, 0},      // green, behind the red one
    {0.4, 0.2, 2.0, 0, 0, 255},      // blue, at (70, 50)
    {-0.6, -0.3, 3.0, 255, 255, 0},  // yellow, at (30, 30)
    {0.2, -0.4, 4.0, 0, 255, 255},   // cyan, at (55, 30)
};

struct PlyOptions {
  bool ascii = false;
  bool doubles = false;
  bool colours = true;
  bool extras = false;  // a property before and after the vertex's own, and an element before the vertices
};

// A PLY file of `points`, written as the options say.
std::string ply_of(const std::vector<Point>& points, const PlyOptions& o) {
  std::ostringstream out;
  out << "ply\nformat " << (o.ascii ? "ascii" : "binary_little_endian") << " 1.0\ncomment test cloud\n";
  if (o.extras) out << "element camera 1\nproperty list uchar int ids\nproperty float view\n";
  out << "element vertex " << points.size() << "\n";
  if (o.extras) out << "property short label\n";
  const char* type = o.doubles ? "double" : "float";
  out << "property " << type << " x\nproperty " << type << " y\nproperty " << type << " z\n";
  if (o.colours) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (o.extras) out << "property float nx\nproperty list uchar int faces\n";
  out << "end_header\n";
  const auto put = [&](auto value) { out.write(reinterpret_cast<const char*>(&value), sizeof value); };
  if (o.extras) {
    if (o.ascii) {
      out << "2 7 8 0.5\n";
    } else {
      put(std::uint8_t{2});
      put(std::int32_t{7});
      put(std::int32_t{8});
      put(0.5f);
    }
  }
  for (const Point& p : points) {
    if (o.ascii) {
      if (o.extras) out << "-3 ";
      out << p.x << " " << p.y << " " << p.z;
      if (o.colours) out << " " << int{p.r} << " " << int{p.g} << " " << int{p.b};
      if (o.extras) out << " 0.25 1 9";
      out << "\n";
      continue;
    }
    if (o.extras) put(std::int16_t{-3});
    if (o.doubles) {
      put(p.x);
      put(p.y);
      put(p.z);
    } else {
      put(static_cast<float>(p.x));
      put(static_cast<float>(p.y));
      put(static_cast<float>(p.z));
    }
    if (o.colours) {
      put(p.r);
      put(p.g);
      put(p.b);
    }
    if (o.extras) {
      put(0.25f);
      put(std::uint8_t{1});
      put(std::int32_t{9});
    }
  }
  return out.str();
}

class Render : public mctstereo::test::FolderTest {
 protected:

  // Renders `cloud` (a file in the folder) with the view that puts kCloud's points on whole pixels
  // (with yaw 0).
  cv::Mat render_front(const std::string& cloud, const std::string& flags = "--yaw 0 --point-size 1") const {
    const Result r = run("render " + cloud + " -o view.png --pitch 0 --focal 100 --size 101x81 " + flags);
    EXPECT_EQ(r.status, 0) << r.output;
    return cv::imread((folder_ / "view.png").string(), cv::IMREAD_COLOR);
  }

  void expect_failure(const std::string& args, int status, const std::string& message) const {
    const Result r = run(args);
    EXPECT_EQ(r.status, status) << args << "\n" << r.output;
    EXPECT_EQ(r.output.rfind("mctstereo: error: ", 0), 0u) << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << args << "\nexpected: " << message << "\ngot: " << r.output;
    EXPECT_FALSE(fs::exists(folder_ / "view.png")) << args;
  }
};

cv::Vec3b bgr(std::uint8_t r, std::uint8_t g, std::uint8_t b) { return {b, g, r}; }

TEST_F(Render, PointsLandWhereThePinholeProjectsThemAndTheNearestWins) {
  write("cloud.ply", ply_of(kCloud, {}));
  const cv::Mat view = render_front("cloud.ply");
  ASSERT_EQ(view.size(), cv::Size(101, 81));
  EXPECT_EQ(view.at<cv::Vec3b>(40, 50), bgr(255, 0, 0));  // red hides green, twice as far on the same ray
  EXPECT_EQ(view.at<cv::Vec3b>(50, 70), bgr(0, 0, 255));
  EXPECT_EQ(view.at<cv::Vec3b>(30, 30), bgr(255, 255, 0));
  EXPECT_EQ(view.at<cv::Vec3b>(30, 55), bgr(0, 255, 255));
  int lit = 0;
  for (int y = 0; y < view.rows; ++y)
    for (int x = 0; x < view.cols; ++x) lit += view.at<cv::Vec3b>(y, x) != cv::Vec3b(0, 0, 0) ? 1 : 0;
  EXPECT_EQ(lit, 4) << "every other pixel is the black background";

  // Without the red point the green one behind it shows.
  std::vector<Point> without_red(kCloud.begin() + 1, kCloud.end());
  without_red.push_back({0.0, 0.0, 3.0, 10, 20, 30});  // keeps the centre on the axis, hidden by nothing
  write("green.ply", ply_of(without_red, {}));
  const cv::Mat behind = render_front("green.ply");
  EXPECT_EQ(behind.at<cv::Vec3b>(40, 50), bgr(10, 20, 30));
  write("green_only.ply", ply_of({kCloud[1], kCloud[2], kCloud[3], kCloud[4], {0.0, 0.1, 3.0, 1, 2, 3}}, {}));
  EXPECT_EQ(render_front("green_only.ply").at<cv::Vec3b>(40, 50), bgr(0, 255, 0));
}

TEST_F(Render, PointSizeAndBackground) {
  write("cloud.ply", ply_of(kCloud, {}));
  const cv::Mat view = render_front("cloud.ply", "--yaw 0 --point-size 3 --background 10,20,30");
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) EXPECT_EQ(view.at<cv::Vec3b>(50 + dy, 70 + dx), bgr(0, 0, 255));
  EXPECT_EQ(view.at<cv::Vec3b>(50, 72), bgr(10, 20, 30));
  EXPECT_EQ(view.at<cv::Vec3b>(0, 0), bgr(10, 20, 30));
}

TEST_F(Render, YawTurnsTheCameraAroundTheCentre) {
  write("cloud.ply", ply_of(kCloud, {}));
  // Yaw 90: the camera at (-3, 0, 3), looking along +X, its right towards -Z. The red point
  // (0, 0, 2) is 3 ahead and 1 right: u = 50 + 100 / 3; the green one (0, 0, 4) 1 left.
  const cv::Mat view = render_front("cloud.ply", "--yaw 90 --point-size 1");
  EXPECT_EQ(view.at<cv::Vec3b>(40, 83), bgr(255, 0, 0));
  EXPECT_EQ(view.at<cv::Vec3b>(40, 17), bgr(0, 255, 0));
}

TEST_F(Render, AsciiBinaryDoublesAndExtraPropertiesDrawTheSamePicture) {
  write("binary.ply", ply_of(kCloud, {}));
  const cv::Mat reference = render_front("binary.ply");
  for (const PlyOptions& o : {PlyOptions{true, false, true, false}, PlyOptions{false, true, true, false},
                              PlyOptions{false, false, true, true}, PlyOptions{true, true, true, true}}) {
    write("other.ply", ply_of(kCloud, o));
    const cv::Mat view = render_front("other.ply");
    ASSERT_EQ(view.size(), reference.size());
    EXPECT_EQ(cv::norm(view, reference, cv::NORM_INF), 0.0)
        << "ascii " << o.ascii << " doubles " << o.doubles << " extras " << o.extras;
  }
}

TEST_F(Render, CloudsWithoutColoursAreGrayNearerLighter) {
  write("plain.ply", ply_of(kCloud, {.colours = false}));
  const cv::Mat view = render_front("plain.ply");
  const cv::Vec3b near = view.at<cv::Vec3b>(40, 50), far = view.at<cv::Vec3b>(30, 55);
  EXPECT_EQ(near[0], near[1]);
  EXPECT_EQ(near[1], near[2]);
  EXPECT_EQ(far[0], far[2]);
  EXPECT_GT(near[0], far[0]);
  EXPECT_GT(far[0], 0);
}

TEST_F(Render, DefaultViewFitsTheCloud) {
  write("cloud.ply", ply_of(kCloud, {}));
  const Result r = run("render cloud.ply -o view.jpg");
  ASSERT_EQ(r.status, 0) << r.output;
  const cv::Mat view = cv::imread((folder_ / "view.jpg").string(), cv::IMREAD_COLOR);
  EXPECT_EQ(view.size(), cv::Size(800, 600));
  EXPECT_NE(r.output.find("5 points, 5 in view"), std::string::npos) << r.output;
  // The picture itself, not the program's count: in a lossless copy every point's colour is drawn
  // somewhere (the green one may hide behind the red one from this view), and nothing else.
  ASSERT_EQ(run("render cloud.ply -o view.png").status, 0);
  const cv::Mat exact = cv::imread((folder_ / "view.png").string(), cv::IMREAD_COLOR);
  ASSERT_EQ(exact.size(), cv::Size(800, 600));
  int found = 0;
  for (const Point& p : kCloud) {
    const cv::Vec3b colour = bgr(p.r, p.g, p.b);
    bool drawn = false;
    for (int y = 0; y < exact.rows && !drawn; ++y)
      for (int x = 0; x < exact.cols && !drawn; ++x) drawn = exact.at<cv::Vec3b>(y, x) == colour;
    found += drawn;
  }
  EXPECT_GE(found, 4);
  int other = 0;
  for (int y = 0; y < exact.rows; ++y)
    for (int x = 0; x < exact.cols; ++x) {
      const cv::Vec3b c = exact.at<cv::Vec3b>(y, x);
      bool known = c == cv::Vec3b(0, 0, 0);
      for (const Point& p : kCloud) known = known || c == bgr(p.r, p.g, p.b);
      other += !known;
    }
  EXPECT_EQ(other, 0);
}

TEST_F(Render, BadFilesAndFlagsAreRefused) {
  write("cloud.ply", ply_of(kCloud, {}));
  std::string big_endian = ply_of(kCloud, {});
  big_endian.replace(big_endian.find("binary_little_endian"), 20, "binary_big_endian");
  write("big.ply", big_endian);
  expect_failure("render big.ply -o view.png", 1, "point cloud 'big.ply' is in the format 'binary_big_endian'");
  write("empty.ply", ply_of({}, {}));
  expect_failure("render empty.ply -o view.png", 1, "point cloud 'empty.ply' has no vertices");
  const std::string whole = ply_of(kCloud, {});
  write("cut.ply", whole.substr(0, whole.size() - 10));
  expect_failure("render cut.ply -o view.png", 1, "point cloud 'cut.ply' is truncated: it ends in vertex 5 of 5");
  std::string no_z = ply_of(kCloud, {.ascii = true});
  no_z.replace(no_z.find("property float z"), 16, "property float w");
  write("no_z.ply", no_z);
  expect_failure("render no_z.ply -o view.png", 1, "point cloud 'no_z.ply': the vertices have no property z");
  std::string bad_number = ply_of(kCloud, {.ascii = true});
  bad_number.replace(bad_number.rfind("0.2"), 3, "abc");
  write("bad_number.ply", bad_number);
  expect_failure("render bad_number.ply -o view.png", 1, "'abc' in vertex 5 is not a number");
  write("faces.ply",
        "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_index\nend_header\n3 0 1 2\n");
  expect_failure("render faces.ply -o view.png", 1, "point cloud 'faces.ply' has no vertex element");
  write("text.ply", "hello\n");
  expect_failure("render text.ply -o view.png", 1, "point cloud 'text.ply' is not a PLY file");
  expect_failure("render missing.ply -o view.png", 1, "cannot read point cloud 'missing.ply': no such file");
  expect_failure("render cloud.ply -o cloud.ply", 2, "refusing to overwrite an input");
  expect_failure("render cloud.ply -o view.png --size 800", 2, "--size '800'");
  expect_failure("render cloud.ply -o view.png --background purple", 2, "--background 'purple'");
  expect_failure("render cloud.ply -o view.txt", 2, "cannot write an image with this extension");
}

TEST_F(Render, HelpStatesTheConventions) {
  const Result r = run("render --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.output.find("X right, Y down, Z forward"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--point-size"), std::string::npos);
}

}  // namespace
