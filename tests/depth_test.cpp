// Depth maps and point clouds from disparity: known pixels against the formulas, and the PLY and
// OBJ files read back.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/depth.hpp"
#include "mctstereo/matcher.hpp"

namespace mctstereo {
namespace {

constexpr std::int16_t kInvalid = -16;  // (dmin - 1) * 16 with dmin = 0
const float kInf = std::numeric_limits<float>::infinity();

StereoGeometry test_geometry() {
  StereoGeometry g;
  g.focal = 100.0;
  g.cx = 1.5;
  g.cy = 0.75;
  g.baseline = 0.5;
  g.doffs = 2.0;
  g.units = "m";
  return g;
}

// A Q4 map of `width` x `height` inside rows of `stride` elements; the padding holds values that
// would be valid, so reading it would show.
struct Q4Map {
  int width, height, stride;
  std::vector<std::int16_t> values;
  Q4Map(int w, int h, int s) : width(w), height(h), stride(s), values(static_cast<std::size_t>(s) * h, 16 * 7) {}
  std::int16_t& at(int x, int y) { return values[static_cast<std::size_t>(y) * stride + x]; }
  MapView<const std::int16_t> view() const { return {values.data(), width, height, stride}; }
};

struct FloatMap {
  int width, height, stride;
  std::vector<float> values;
  FloatMap(int w, int h, int s, float fill)
      : width(w), height(h), stride(s), values(static_cast<std::size_t>(s) * h, fill) {}
  float& at(int x, int y) { return values[static_cast<std::size_t>(y) * stride + x]; }
  MapView<float> view() { return {values.data(), width, height, stride}; }
};

// Z of the formula, correctly rounded to float.
float expected_depth(double d, const StereoGeometry& g) {
  return static_cast<float>(g.focal * g.baseline / (d + g.doffs));
}

// A 4 x 3 map (stride 6) with integer, sub-pixel, zero and negative d + doffs, and invalid pixels.
Q4Map known_map() {
  Q4Map m(4, 3, 6);
  const std::int16_t row0[] = {16 * 10, 16 * 10 + 8, 16 * 10 + 1, kInvalid};  // d = 10, 10.5, 10.0625, none
  const std::int16_t row1[] = {-32, -48, 16 * 48, 0};                          // d + doffs = 0, -1; d = 48, 0
  const std::int16_t row2[] = {16 * 3, 16 * 1, 5, 16 * 98};                    // d = 3, 1, 0.3125, 98
  for (int x = 0; x < 4; ++x) {
    m.at(x, 0) = row0[x];
    m.at(x, 1) = row1[x];
    m.at(x, 2) = row2[x];
  }
  return m;
}

TEST(Depth, KnownPixelsOfAQ4MapFollowTheFormula) {
  const StereoGeometry g = test_geometry();  // f B = 50
  const Q4Map q4 = known_map();
  FloatMap depth(4, 3, 5, -7.0f);
  depth_from_disparity(q4.view(), kInvalid, g, depth.view());
  EXPECT_EQ(depth.at(0, 0), expected_depth(10.0, g));  // 50 / 12
  EXPECT_EQ(depth.at(1, 0), 4.0f);                     // 50 / 12.5
  EXPECT_EQ(depth.at(2, 0), expected_depth(10.0625, g));
  EXPECT_TRUE(std::isnan(depth.at(3, 0)));  // invalid
  EXPECT_TRUE(std::isnan(depth.at(0, 1)));  // d + doffs = 0: at infinity
  EXPECT_TRUE(std::isnan(depth.at(1, 1)));  // d + doffs < 0: behind the camera
  EXPECT_EQ(depth.at(2, 1), 1.0f);          // 50 / 50
  EXPECT_EQ(depth.at(3, 1), 25.0f);         // d = 0 is a depth when doffs > 0
  EXPECT_EQ(depth.at(0, 2), 10.0f);
  EXPECT_EQ(depth.at(1, 2), expected_depth(1.0, g));
  EXPECT_EQ(depth.at(2, 2), expected_depth(0.3125, g));
  EXPECT_EQ(depth.at(3, 2), 0.5f);
  // The padding of the depth rows is not written.
  for (int y = 0; y < 3; ++y) EXPECT_EQ(depth.values[static_cast<std::size_t>(y) * 5 + 4], -7.0f);
}

TEST(Depth, MaxDepthCutsTheFarField) {
  const StereoGeometry g = test_geometry();
  const Q4Map q4 = known_map();
  FloatMap depth(4, 3, 4, 0.0f);
  depth_from_disparity(q4.view(), kInvalid, g, depth.view(), 4.0);
  EXPECT_TRUE(std::isnan(depth.at(0, 0)));  // 4.17 > 4
  EXPECT_EQ(depth.at(1, 0), 4.0f);          // exactly the limit stays
  EXPECT_TRUE(std::isnan(depth.at(3, 1)));  // 25
  EXPECT_EQ(depth.at(2, 1), 1.0f);
  EXPECT_TRUE(std::isnan(depth.at(0, 2)));  // 10
  EXPECT_EQ(depth.at(3, 2), 0.5f);
  EXPECT_THROW(depth_from_disparity(q4.view(), kInvalid, g, depth.view(), 0.0), std::invalid_argument);
  EXPECT_THROW(depth_from_disparity(q4.view(), kInvalid, g, depth.view(), std::nan("")), std::invalid_argument);
}

TEST(Depth, FloatDisparityGivesTheSameDepths) {
  const StereoGeometry g = test_geometry();
  FloatMap disparity(3, 2, 4, 0.0f);
  const float d[2][3] = {{10.0f, 10.5f, std::nanf("")}, {kInf, -kInf, -2.0f}};
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) disparity.at(x, y) = d[y][x];
  FloatMap depth(3, 2, 3, 0.0f);
  const MapView<const float> input{disparity.values.data(), 3, 2, 4};
  depth_from_disparity(input, g, depth.view());
  EXPECT_EQ(depth.at(0, 0), expected_depth(10.0, g));
  EXPECT_EQ(depth.at(1, 0), 4.0f);
  for (int x = 0; x < 3; ++x) EXPECT_TRUE(std::isnan(depth.at(x, 1))) << x;
  EXPECT_TRUE(std::isnan(depth.at(2, 0)));
  depth_from_disparity(input, g, depth.view(), 4.0);
  EXPECT_TRUE(std::isnan(depth.at(0, 0)));
  EXPECT_EQ(depth.at(1, 0), 4.0f);
}

TEST(Depth, RejectsOtherSizesAndBadGeometry) {
  const Q4Map q4 = known_map();
  FloatMap wrong(3, 3, 3, 0.0f);
  EXPECT_THROW(depth_from_disparity(q4.view(), kInvalid, test_geometry(), wrong.view()), std::invalid_argument);
  EXPECT_THROW(relative_depth_from_disparity(q4.view(), kInvalid, wrong.view()), std::invalid_argument);
  FloatMap depth(4, 3, 4, 0.0f);
  const auto message_of = [&](StereoGeometry g) -> std::string {
    try {
      depth_from_disparity(q4.view(), kInvalid, g, depth.view());
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "no error";
  };
  StereoGeometry g = test_geometry();
  g.focal = 0.0;
  EXPECT_NE(message_of(g).find("focal"), std::string::npos) << message_of(g);
  g = test_geometry();
  g.baseline = -1.0;
  EXPECT_NE(message_of(g).find("baseline"), std::string::npos) << message_of(g);
  g = test_geometry();
  g.cy = std::nan("");
  EXPECT_NE(message_of(g).find("cy"), std::string::npos) << message_of(g);
  g = test_geometry();
  g.doffs = std::numeric_limits<double>::infinity();
  EXPECT_NE(message_of(g).find("doffs"), std::string::npos) << message_of(g);
}

TEST(Depth, RelativeDepthIsOneOverDisparity) {
  const Q4Map q4 = known_map();
  FloatMap depth(4, 3, 4, 0.0f);
  relative_depth_from_disparity(q4.view(), kInvalid, depth.view());
  EXPECT_EQ(depth.at(0, 0), 0.1f);
  EXPECT_EQ(depth.at(1, 0), static_cast<float>(1.0 / 10.5));
  EXPECT_TRUE(std::isnan(depth.at(3, 0)));  // invalid
  EXPECT_TRUE(std::isnan(depth.at(0, 1)));  // d < 0
  EXPECT_TRUE(std::isnan(depth.at(3, 1)));  // d = 0
  EXPECT_EQ(depth.at(2, 2), 3.2f);          // 1 / 0.3125
}

TEST(Depth, GeometryScalesAroundPixelCentres) {
  const StereoGeometry g = test_geometry();
  const StereoGeometry half = g.scaled(0.5);
  EXPECT_DOUBLE_EQ(half.focal, 50.0);
  EXPECT_DOUBLE_EQ(half.cx, 0.5);    // (1.5 + 0.5) / 2 - 0.5
  EXPECT_DOUBLE_EQ(half.cy, 0.125);  // (0.75 + 0.5) / 2 - 0.5
  EXPECT_DOUBLE_EQ(half.doffs, 1.0);
  EXPECT_DOUBLE_EQ(half.baseline, 0.5);
  EXPECT_EQ(half.units, "m");
  // A disparity halves with the image, so the depth of a scene point stays.
  EXPECT_DOUBLE_EQ(half.depth(5.0), g.depth(10.0));
  EXPECT_DOUBLE_EQ(g.depth(10.5), 4.0);
  EXPECT_EQ(g.depth(-2.0), std::numeric_limits<double>::infinity());
  EXPECT_EQ(g.depth(-3.0), std::numeric_limits<double>::infinity());
  EXPECT_THROW((void)g.scaled(0.0), std::invalid_argument);
  EXPECT_NO_THROW(g.validate());
}

// An 8-bit image with `channels` per pixel, `stride` bytes per row, pixel (x, y) channel c = 10 y + 3 x + c.
struct TestImage {
  std::vector<std::uint8_t> bytes;
  ImageView view;
  TestImage(int w, int h, PixelFormat format, std::ptrdiff_t stride)
      : bytes(static_cast<std::size_t>(stride) * h, 255) {
    const int channels = bytes_per_pixel(format);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < channels; ++c)
          bytes[y * stride + x * channels + c] = static_cast<std::uint8_t>(10 * y + 3 * x + c);
    view = ImageView{bytes.data(), w, h, stride, format};
  }
};

TEST(PointCloud, KnownPixelsBackProjectWithTheirColours) {
  const StereoGeometry g = test_geometry();
  const Q4Map q4 = known_map();
  const TestImage rgb(4, 3, PixelFormat::Rgb8, 13);
  PointCloud cloud;
  point_cloud_from_disparity(q4.view(), kInvalid, g, rgb.view, cloud);
  // Valid pixels with a depth in row order: row 0 x 0..2, row 1 x 2..3, row 2 x 0..3.
  const std::vector<std::int32_t> pixels = {0, 1, 2, 6, 7, 8, 9, 10, 11};
  ASSERT_EQ(cloud.pixel, pixels);
  ASSERT_EQ(cloud.size(), 9u);
  ASSERT_EQ(cloud.xyz.size(), 27u);
  ASSERT_TRUE(cloud.has_colours());
  EXPECT_EQ(cloud.units, "m");
  FloatMap depth(4, 3, 4, 0.0f);
  depth_from_disparity(q4.view(), kInvalid, g, depth.view());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const int x = pixels[i] % 4, y = pixels[i] / 4;
    const double d = q4.values[static_cast<std::size_t>(y) * 6 + x] / 16.0;
    const double z = g.focal * g.baseline / (d + g.doffs);
    EXPECT_EQ(cloud.xyz[3 * i + 2], depth.at(x, y)) << x << "," << y;
    EXPECT_EQ(cloud.xyz[3 * i + 2], static_cast<float>(z));
    EXPECT_FLOAT_EQ(cloud.xyz[3 * i + 0], static_cast<float>((x - g.cx) * z / g.focal)) << x << "," << y;
    EXPECT_FLOAT_EQ(cloud.xyz[3 * i + 1], static_cast<float>((y - g.cy) * z / g.focal)) << x << "," << y;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(cloud.rgb[3 * i + c], 10 * y + 3 * x + c);
  }
  // Pixel (1, 0): d = 10.5, Z = 4, X = (1 - 1.5) 4 / 100, Y = (0 - 0.75) 4 / 100.
  EXPECT_FLOAT_EQ(cloud.xyz[3], -0.02f);
  EXPECT_FLOAT_EQ(cloud.xyz[4], -0.03f);
  EXPECT_EQ(cloud.xyz[5], 4.0f);
}

TEST(PointCloud, ColoursFromGrayAndBgrAndNone) {
  const StereoGeometry g = test_geometry();
  const Q4Map q4 = known_map();
  PointCloud gray_cloud, bgr_cloud, plain;
  const TestImage gray(4, 3, PixelFormat::Gray8, 5);
  const TestImage bgr(4, 3, PixelFormat::Bgr8, 12);
  point_cloud_from_disparity(q4.view(), kInvalid, g, gray.view, gray_cloud);
  point_cloud_from_disparity(q4.view(), kInvalid, g, bgr.view, bgr_cloud);
  point_cloud_from_disparity(q4.view(), kInvalid, g, ImageView{}, plain);
  ASSERT_EQ(gray_cloud.size(), 9u);
  ASSERT_EQ(bgr_cloud.size(), 9u);
  ASSERT_EQ(plain.size(), 9u);
  EXPECT_FALSE(plain.has_colours());
  EXPECT_EQ(plain.xyz, gray_cloud.xyz);
  for (std::size_t i = 0; i < 9; ++i) {
    const int x = gray_cloud.pixel[i] % 4, y = gray_cloud.pixel[i] / 4;
    const int v = 10 * y + 3 * x;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(gray_cloud.rgb[3 * i + c], v);
    EXPECT_EQ(bgr_cloud.rgb[3 * i + 0], v + 2);  // R is the third byte of BGR
    EXPECT_EQ(bgr_cloud.rgb[3 * i + 1], v + 1);
    EXPECT_EQ(bgr_cloud.rgb[3 * i + 2], v + 0);
  }
  const TestImage small(3, 3, PixelFormat::Gray8, 3);
  EXPECT_THROW(point_cloud_from_disparity(q4.view(), kInvalid, g, small.view, plain), std::invalid_argument);
}

TEST(PointCloud, MaxDepthDropsPointsAndReuseAllocatesNothing) {
  const StereoGeometry g = test_geometry();
  Q4Map q4 = known_map();
  const TestImage rgb(4, 3, PixelFormat::Rgb8, 12);
  PointCloud cloud;
  point_cloud_from_disparity(q4.view(), kInvalid, g, rgb.view, cloud);
  ASSERT_EQ(cloud.size(), 9u);
  const float* xyz = cloud.xyz.data();
  const std::uint8_t* colours = cloud.rgb.data();
  const std::int32_t* pixels = cloud.pixel.data();
  // Z: 4.17, 4, 4.15, 1, 25, 10, 16.7, 21.9, 0.5; at most 4 leaves (1,0), (2,1) and (3,2).
  point_cloud_from_disparity(q4.view(), kInvalid, g, rgb.view, cloud, 4.0);
  EXPECT_EQ(cloud.pixel, (std::vector<std::int32_t>{1, 6, 11}));
  EXPECT_EQ(cloud.xyz.size(), 9u);
  EXPECT_EQ(cloud.rgb.size(), 9u);
  // The same frame again, and a frame with fewer points: the storage stays where it was.
  point_cloud_from_disparity(q4.view(), kInvalid, g, rgb.view, cloud);
  EXPECT_EQ(cloud.size(), 9u);
  q4.at(0, 0) = kInvalid;
  point_cloud_from_disparity(q4.view(), kInvalid, g, rgb.view, cloud);
  EXPECT_EQ(cloud.size(), 8u);
  EXPECT_EQ(cloud.xyz.data(), xyz);
  EXPECT_EQ(cloud.rgb.data(), colours);
  EXPECT_EQ(cloud.pixel.data(), pixels);
  cloud.clear();
  EXPECT_EQ(cloud.size(), 0u);
  EXPECT_GE(cloud.xyz.capacity(), 27u);
}

// A PLY file read back: the header lines and the vertices.
struct Ply {
  std::vector<std::string> header;
  std::size_t vertices = 0;
  bool colours = false;
  std::vector<float> xyz;
  std::vector<std::uint8_t> rgb;
};

Ply read_ply(const std::string& bytes) {
  Ply ply;
  std::size_t at = 0;
  while (true) {
    const std::size_t end = bytes.find('\n', at);
    if (end == std::string::npos) {
      ADD_FAILURE() << "no end_header";
      return ply;
    }
    ply.header.push_back(bytes.substr(at, end - at));
    at = end + 1;
    if (ply.header.back() == "end_header") break;
  }
  for (const std::string& line : ply.header) {
    if (line.rfind("element vertex ", 0) == 0) ply.vertices = std::stoul(line.substr(15));
    if (line == "property uchar red") ply.colours = true;
  }
  const std::size_t record = 12 + (ply.colours ? 3 : 0);
  EXPECT_EQ(bytes.size() - at, ply.vertices * record);
  if (bytes.size() - at != ply.vertices * record) return ply;
  for (std::size_t i = 0; i < ply.vertices; ++i) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data() + at + i * record);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t bits =
          p[4 * k] | p[4 * k + 1] << 8 | p[4 * k + 2] << 16 | std::uint32_t(p[4 * k + 3]) << 24;
      float v;
      std::memcpy(&v, &bits, 4);
      ply.xyz.push_back(v);
    }
    if (ply.colours)
      for (int k = 0; k < 3; ++k) ply.rgb.push_back(p[12 + k]);
  }
  return ply;
}

TEST(PointCloudFiles, PlyHoldsTheHeaderAndEveryPoint) {
  const Q4Map q4 = known_map();
  const TestImage rgb(4, 3, PixelFormat::Rgb8, 12);
  PointCloud cloud;
  point_cloud_from_disparity(q4.view(), kInvalid, test_geometry(), rgb.view, cloud);
  std::ostringstream out;
  write_ply(out, cloud, {"units m", "two\nlines"});
  const Ply ply = read_ply(out.str());
  const std::vector<std::string> header = {"ply",
                                           "format binary_little_endian 1.0",
                                           "comment units m",
                                           "comment two lines",
                                           "element vertex 9",
                                           "property float x",
                                           "property float y",
                                           "property float z",
                                           "property uchar red",
                                           "property uchar green",
                                           "property uchar blue",
                                           "end_header"};
  EXPECT_EQ(ply.header, header);
  EXPECT_EQ(ply.vertices, 9u);
  EXPECT_EQ(ply.xyz, cloud.xyz);
  EXPECT_EQ(ply.rgb, cloud.rgb);

  PointCloud plain;
  point_cloud_from_disparity(q4.view(), kInvalid, test_geometry(), ImageView{}, plain);
  std::ostringstream plain_out;
  write_ply(plain_out, plain);
  const Ply plain_ply = read_ply(plain_out.str());
  EXPECT_FALSE(plain_ply.colours);
  EXPECT_EQ(plain_ply.header.size(), 7u);
  EXPECT_EQ(plain_ply.xyz, cloud.xyz);
}

TEST(PointCloudFiles, ObjHoldsEveryPointAsAVertexLine) {
  const Q4Map q4 = known_map();
  const TestImage bgr(4, 3, PixelFormat::Bgr8, 12);
  PointCloud cloud;
  point_cloud_from_disparity(q4.view(), kInvalid, test_geometry(), bgr.view, cloud);
  std::ostringstream out;
  write_obj(out, cloud, {"units m"});
  std::istringstream lines(out.str());
  std::string line;
  ASSERT_TRUE(std::getline(lines, line));
  EXPECT_EQ(line, "# units m");
  std::size_t n = 0;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string v;
    float x, y, z, r, g, b;
    ASSERT_TRUE(words >> v >> x >> y >> z >> r >> g >> b) << line;
    EXPECT_EQ(v, "v");
    ASSERT_LT(n, cloud.size());
    EXPECT_EQ(x, cloud.xyz[3 * n + 0]) << line;
    EXPECT_EQ(y, cloud.xyz[3 * n + 1]) << line;
    EXPECT_EQ(z, cloud.xyz[3 * n + 2]) << line;
    EXPECT_EQ(std::lround(r * 255.0f), cloud.rgb[3 * n + 0]) << line;
    EXPECT_EQ(std::lround(g * 255.0f), cloud.rgb[3 * n + 1]) << line;
    EXPECT_EQ(std::lround(b * 255.0f), cloud.rgb[3 * n + 2]) << line;
    ++n;
  }
  EXPECT_EQ(n, 9u);
}

}  // namespace
}  // namespace mctstereo
