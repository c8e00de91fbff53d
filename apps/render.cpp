#include "render.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "errors.hpp"
#include "input_files.hpp"
#include "mctstereo/depth.hpp"
#include "output_files.hpp"
#include "statistics.hpp"

namespace mctstereo::app {

namespace {

namespace fs = std::filesystem;

constexpr const char* kRenderFooter = R"(Conventions:
  Points are in the frame of the camera that saw them: X right, Y down, Z forward (the left
  rectified camera for clouds of mctstereo), in the cloud's units.
  The view camera circles the centre of the cloud (the median of its points) and always looks at
  it. With --yaw 0 --pitch 0 --distance 1 it stands where the original camera stood (the origin),
  turned towards the centre. --yaw turns it about the vertical axis through the centre (positive:
  from the left), --pitch about the horizontal one (negative: from above, looking down), and
  --distance scales its distance to the centre (2: twice as far).
  The principal point is the centre of the picture; without --focal the focal length fits 99.5 %
  of the points into it. Each point is a square of --point-size pixels; where points overlap, the
  nearest one is drawn. Clouds without colours are drawn in gray, lighter where nearer.
  PLY files: ascii or binary_little_endian, vertex x y z (float or double) with optional red green
  blue (uchar); other properties and elements are skipped.
)";

// The cloud of a PLY file (mctstereo::read_ply), with the file's name in messages.
PointCloud read_cloud(const std::string& path) {
  const std::string where = "point cloud " + in_quotes(path);
  // Only a regular file is read (a FIFO would hang), with the program's messages for what is missing.
  std::istringstream in(read_input_file(path, "point cloud"));
  try {
    return read_ply(in, where);
  } catch (const std::runtime_error& e) {
    throw RuntimeError(e.what());
  }
}

// A focal length beyond any camera's: the picture would be one pixel of the cloud.
constexpr double kMaxFocal = 1e9;

// ---- the view ---------------------------------------------------------------------------------

// One side of --size: digits only, so that neither a sign nor a wrap-around ("4294967297" read as
// 1) gets through; nullopt outside 1 .. kMaxSide.
constexpr int kMaxSide = 16384;

std::optional<int> parse_side(const std::string& digits) {
  if (digits.empty() || digits.size() > 5 || digits.find_first_not_of("0123456789") != std::string::npos)
    return std::nullopt;
  const int side = std::stoi(digits);
  if (side < 1 || side > kMaxSide) return std::nullopt;
  return side;
}

cv::Size parse_size(const std::string& text) {
  const std::size_t x = text.find_first_of("xX");
  const std::optional<int> width = x == std::string::npos ? std::nullopt : parse_side(text.substr(0, x));
  const std::optional<int> height = x == std::string::npos ? std::nullopt : parse_side(text.substr(x + 1));
  if (!width || !height)
    throw UsageError("--size '" + text + "': expected WIDTHxHEIGHT, each 1 .. " + std::to_string(kMaxSide) +
                     ", e.g. 800x600");
  return {*width, *height};
}

cv::Vec3b parse_colour(const std::string& text) {  // as B, G, R
  if (text == "black") return {0, 0, 0};
  if (text == "white") return {255, 255, 255};
  if (text == "gray" || text == "grey") return {128, 128, 128};
  unsigned r = 0, g = 0, b = 0;
  char extra = 0;
  if (text.size() == 7 && text[0] == '#' &&
      std::sscanf(text.c_str(), "#%2x%2x%2x%c", &r, &g, &b, &extra) == 3 &&
      text.find_first_not_of("0123456789abcdefABCDEF", 1) == std::string::npos)
    return {static_cast<std::uint8_t>(b), static_cast<std::uint8_t>(g), static_cast<std::uint8_t>(r)};
  int ri = -1, gi = -1, bi = -1;
  if (std::sscanf(text.c_str(), "%d,%d,%d%c", &ri, &gi, &bi, &extra) == 3 && ri >= 0 && ri <= 255 && gi >= 0 &&
      gi <= 255 && bi >= 0 && bi <= 255)
    return {static_cast<std::uint8_t>(bi), static_cast<std::uint8_t>(gi), static_cast<std::uint8_t>(ri)};
  throw UsageError("--background '" + text + "': expected black, white, gray, #RRGGBB or R,G,B (0 .. 255)");
}

cv::Matx33d rotation_about_x(double radians) {
  const double c = std::cos(radians), s = std::sin(radians);
  return {1, 0, 0, 0, c, -s, 0, s, c};
}

cv::Matx33d rotation_about_y(double radians) {
  const double c = std::cos(radians), s = std::sin(radians);
  return {c, 0, s, 0, 1, 0, -s, 0, c};
}

// The rotation (camera to world) of a camera looking along `forward` with the world's Y (down)
// as its down, as far as it can be.
cv::Matx33d looking_along(const cv::Vec3d& forward) {
  const cv::Vec3d z = cv::normalize(forward);
  cv::Vec3d x = cv::Vec3d(0, 1, 0).cross(z);
  if (cv::norm(x) < 1e-9) x = {1, 0, 0};  // straight up or down
  x = cv::normalize(x);
  const cv::Vec3d y = z.cross(x);
  return {x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]};
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string point_text(const cv::Vec3d& p) {
  return "(" + fixed(p[0], 3) + ", " + fixed(p[1], 3) + ", " + fixed(p[2], 3) + ")";
}


cv::Vec3d point_of(const PointCloud& cloud, std::size_t i) {
  return {cloud.xyz[3 * i], cloud.xyz[3 * i + 1], cloud.xyz[3 * i + 2]};
}

// The indices of the points whose three coordinates are finite.
std::vector<std::size_t> finite_points(const PointCloud& cloud) {
  std::vector<std::size_t> finite;
  finite.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (std::isfinite(cloud.xyz[3 * i]) && std::isfinite(cloud.xyz[3 * i + 1]) && std::isfinite(cloud.xyz[3 * i + 2]))
      finite.push_back(i);
  return finite;
}

// Where the view camera stands and how it is turned.
struct ViewPose {
  cv::Vec3d centre;  // what it looks at: the median of each coordinate, which stray points do not move
  cv::Vec3d camera;  // its position
  cv::Matx33d world_to_camera;
  double near = 0;   // points at or behind this depth in its frame are not drawn
};

ViewPose view_pose(const PointCloud& cloud, const std::vector<std::size_t>& finite, double yaw_degrees,
                   double pitch_degrees, double distance) {
  ViewPose pose;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> coordinate;
    coordinate.reserve(finite.size());
    for (std::size_t i : finite) coordinate.push_back(cloud.xyz[3 * i + axis]);
    pose.centre[axis] = median(coordinate);
  }
  // From the centre to the original camera (the origin); a cloud centred on the origin is seen
  // from behind it, from twice its median radius.
  cv::Vec3d offset = -pose.centre;
  if (cv::norm(offset) < 1e-12) {
    std::vector<double> radius;
    for (std::size_t i : finite) radius.push_back(cv::norm(point_of(cloud, i) - pose.centre));
    const double r = median(radius);
    offset = {0, 0, -2.0 * (r > 0 ? r : 1.0)};
  }
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  const cv::Matx33d turn = rotation_about_y(yaw_degrees * kDegree) * rotation_about_x(pitch_degrees * kDegree);
  pose.world_to_camera = (turn * looking_along(-offset)).t();
  pose.camera = pose.centre + distance * (turn * offset);
  pose.near = 1e-6 * cv::norm(offset) * distance;
  return pose;
}

// The points in the view camera's frame, with their indices in the cloud; those behind it (or at
// it) are left out.
struct PointsInView {
  std::vector<cv::Vec3d> xyz;
  std::vector<std::size_t> source;
};

PointsInView to_camera(const PointCloud& cloud, const std::vector<std::size_t>& finite, const ViewPose& pose) {
  PointsInView points;
  points.xyz.reserve(finite.size());
  points.source.reserve(finite.size());
  for (std::size_t i : finite) {
    const cv::Vec3d p = pose.world_to_camera * (point_of(cloud, i) - pose.camera);
    if (p[2] > pose.near) {
      points.xyz.push_back(p);
      points.source.push_back(i);
    }
  }
  return points;
}

// A focal length that fits 99.5 % of the points into the picture, with a margin of 5 % on each
// side: a few stray points (mismatches) do not shrink the view.
double fitting_focal(const std::vector<cv::Vec3d>& in_camera, cv::Size size) {
  std::vector<double> spread_x, spread_y;
  for (const cv::Vec3d& p : in_camera) {
    spread_x.push_back(std::abs(p[0] / p[2]));
    spread_y.push_back(std::abs(p[1] / p[2]));
  }
  const double sx = percentile(spread_x, 99.5), sy = percentile(spread_y, 99.5);
  const double focal = std::min(sx > 0 ? 0.45 * size.width / sx : 1e30, sy > 0 ? 0.45 * size.height / sy : 1e30);
  return focal < 1e29 ? focal : std::max(size.width, size.height);
}

// Draws each point as a square of point_size pixels, the nearest point winning each pixel: in its
// colour, or for a cloud without colours in gray by depth (nearer is lighter, over the 2nd to 98th
// percentile). Returns the number of points whose centre fell in the picture.
std::size_t draw_points(const PointCloud& cloud, const PointsInView& points, double focal, int point_size,
                        cv::Mat& picture) {
  const cv::Size size = picture.size();
  double near_depth = 0, far_depth = 0;
  if (cloud.rgb.empty() && !points.xyz.empty()) {
    std::vector<double> depths;
    depths.reserve(points.xyz.size());
    for (const cv::Vec3d& p : points.xyz) depths.push_back(p[2]);
    near_depth = percentile(depths, 2.0);
    far_depth = percentile(depths, 98.0);
  }
  const auto gray_of_depth = [&](double z) {
    const double t = far_depth > near_depth ? std::clamp((z - near_depth) / (far_depth - near_depth), 0.0, 1.0) : 0.0;
    const auto level = static_cast<std::uint8_t>(std::lround(230.0 - 140.0 * t));
    return cv::Vec3b(level, level, level);
  };

  const double cx = 0.5 * (size.width - 1), cy = 0.5 * (size.height - 1);
  const std::size_t pixels = static_cast<std::size_t>(size.width) * size.height;
  std::vector<double> depth(pixels, std::numeric_limits<double>::infinity());
  const int lo = -(point_size - 1) / 2, hi = point_size / 2;
  std::size_t in_view = 0;
  for (std::size_t n = 0; n < points.xyz.size(); ++n) {
    const cv::Vec3d& p = points.xyz[n];
    const double u = focal * p[0] / p[2] + cx, v = focal * p[1] / p[2] + cy;
    if (!(u > -point_size - 1.0 && u < size.width + point_size && v > -point_size - 1.0 &&
          v < size.height + point_size))
      continue;
    const int ui = static_cast<int>(std::floor(u + 0.5)), vi = static_cast<int>(std::floor(v + 0.5));
    const std::size_t i = points.source[n];
    const std::uint8_t* rgb = cloud.rgb.empty() ? nullptr : &cloud.rgb[3 * i];
    const cv::Vec3b colour = rgb ? cv::Vec3b(rgb[2], rgb[1], rgb[0]) : gray_of_depth(p[2]);
    in_view += ui >= 0 && ui < size.width && vi >= 0 && vi < size.height ? 1 : 0;
    for (int y = std::max(vi + lo, 0); y <= std::min(vi + hi, size.height - 1); ++y)
      for (int x = std::max(ui + lo, 0); x <= std::min(ui + hi, size.width - 1); ++x) {
        double& nearest = depth[static_cast<std::size_t>(y) * size.width + x];
        if (p[2] < nearest) {
          nearest = p[2];
          picture.at<cv::Vec3b>(y, x) = colour;
        }
      }
  }
  return in_view;
}

}  // namespace

RenderCommand::RenderCommand(CLI::App& parent)
    : command_(parent.add_subcommand("render", "draw a point cloud (PLY) as a picture from a chosen viewpoint")) {
  CLI::App& app = *command_;
  app.footer(kRenderFooter);
  app.add_option("CLOUD", cloud_, "point cloud: PLY, ascii or binary little-endian")->required();
  app.add_option("-o,--output", output_, "picture to write: .png or .jpg")->required();
  app.add_option("--yaw", yaw_, "degrees about the vertical axis through the centre (positive: from the left)")
      ->check(CLI::Range(-360.0, 360.0))
      ->capture_default_str();
  app.add_option("--pitch", pitch_, "degrees about the horizontal axis (negative: from above)")
      ->check(CLI::Range(-89.0, 89.0))
      ->capture_default_str();
  app.add_option("--distance", distance_, "distance to the centre, as a multiple of the original camera's")
      ->check(CLI::Range(0.01, 1000.0))
      ->capture_default_str();
  app.add_option("--size", size_, "picture size WIDTHxHEIGHT")->capture_default_str();
  app.add_option("--focal", focal_, "focal length of the view, pixels (default: fit the cloud into the picture)")
      ->check(CLI::PositiveNumber);
  app.add_option("--point-size", point_size_, "side of the square drawn for each point, pixels")
      ->check(CLI::Range(1, 32))
      ->capture_default_str();
  app.add_option("--background", background_, "colour: black, white, gray, #RRGGBB or R,G,B")->capture_default_str();
}

void RenderCommand::run() const {
  // Every check that needs no reading comes first.
  const cv::Size size = parse_size(size_);
  const cv::Vec3b background = parse_colour(background_);
  if (focal_ > kMaxFocal) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", focal_);
    throw UsageError(std::string("--focal ") + text + " is too large (at most 1e+09 pixels)");
  }
  check_output_path(output_, {cloud_}, "rendered view");
  if (!cv::haveImageWriter(output_))
    throw UsageError("-o " + in_quotes(output_) + ": cannot write an image with this extension (use .png or .jpg)");

  const PointCloud cloud = read_cloud(cloud_);
  const std::vector<std::size_t> finite = finite_points(cloud);
  if (finite.empty()) throw RuntimeError("point cloud " + in_quotes(cloud_) + " has no finite points");

  const ViewPose pose = view_pose(cloud, finite, yaw_, pitch_, distance_);
  const PointsInView points = to_camera(cloud, finite, pose);
  const double focal = focal_ > 0.0 ? focal_ : fitting_focal(points.xyz, size);
  cv::Mat picture(size, CV_8UC3, cv::Scalar(background[0], background[1], background[2]));
  const std::size_t in_view = draw_points(cloud, points, focal, point_size_, picture);

  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(fs::path(output_).extension().string(), picture, bytes))
    throw RuntimeError("cannot encode the rendered view " + in_quotes(output_));
  PendingOutputs outputs;
  outputs.add(output_, bytes);
  outputs.commit();
  std::cout << cloud_ << ": " << cloud.size() << " points, " << in_view << " in view; wrote " << output_ << " ("
            << size.width << "x" << size.height << ", focal " << fixed(focal, 1) << " px, camera at "
            << point_text(pose.camera) << " looking at " << point_text(pose.centre) << ")\n";
}

}  // namespace mctstereo::app
