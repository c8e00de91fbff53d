// Reading PLY point clouds: what write_ply writes, ascii and binary files of other programs (other
// types, properties and elements), and damaged files refused with a message naming them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/depth.hpp"

namespace mctstereo {
namespace {

PointCloud read(const std::string& bytes) {
  std::istringstream in(bytes);
  return read_ply(in, "'c.ply'");
}

std::string message_of(const std::string& bytes) {
  try {
    read(bytes);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

template <typename T>
std::string le(T v) {
  std::string s(sizeof v, '\0');
  std::memcpy(s.data(), &v, sizeof v);  // the test hosts are little-endian, as the format
  return s;
}

TEST(Ply, ReadsWhatWritePlyWrites) {
  PointCloud cloud;
  cloud.xyz = {1.5f, -2.0f, 3.0f, 0.25f, 0.5f, 8.0f};
  cloud.rgb = {255, 0, 10, 1, 2, 3};
  cloud.pixel = {0, 1};
  std::ostringstream out;
  write_ply(out, cloud, {"a comment"});
  const PointCloud back = read(out.str());
  EXPECT_EQ(back.xyz, cloud.xyz);
  EXPECT_EQ(back.rgb, cloud.rgb);
  EXPECT_EQ(back.size(), 2u);
  EXPECT_TRUE(back.pixel.empty());
  EXPECT_EQ(back.units, "");
  cloud.rgb.clear();
  std::ostringstream plain;
  write_ply(plain, cloud);
  EXPECT_FALSE(read(plain.str()).has_colours());
}

TEST(Ply, ReadsAsciiWithOtherTypesPropertiesAndElements) {
  const std::string ascii =
      "ply\r\nformat ascii 1.0\r\ncomment from elsewhere\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\n"
      "element vertex 2\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\nproperty float nx\r\n"
      "property float red\r\nproperty float green\r\nproperty float blue\r\nend_header\r\n"
      "3 0 1 1\r\n"
      "1 2 3 0 1 0.5 0\r\n"
      "4 5 1e40 0 0 0 2\r\n";
  const PointCloud cloud = read(ascii);
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.xyz[0], 1.0f);
  EXPECT_TRUE(std::isnan(cloud.xyz[5]));                                  // beyond float
  EXPECT_EQ(cloud.rgb, (std::vector<std::uint8_t>{255, 128, 0, 0, 0, 255}));  // float colours in [0, 1], clamped
}

TEST(Ply, ReadsBinaryWithIntegerCoordinatesAndAListInTheVertex) {
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty short x\nproperty int y\n"
      "property list uchar float extra\nproperty ushort z\nend_header\n";
  binary += le<std::int16_t>(-3) + le<std::int32_t>(7) + le<std::uint8_t>(2) + le(1.0f) + le(2.0f) + le<std::uint16_t>(9);
  const PointCloud cloud = read(binary);
  EXPECT_EQ(cloud.xyz, (std::vector<float>{-3, 7, 9}));
  EXPECT_FALSE(cloud.has_colours());
}

TEST(Ply, DamagedFilesAreRefusedByName) {
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n";
  EXPECT_EQ(message_of("obj\n"), "'c.ply' is not a PLY file (it does not start with 'ply')");
  EXPECT_NE(message_of("ply\nformat binary_big_endian 1.0\n").find("in the format 'binary_big_endian'"),
            std::string::npos);
  EXPECT_EQ(message_of(header + "property float z\n"), "'c.ply': the header has no end_header line");
  EXPECT_EQ(message_of(header + "end_header\n1 2\n"), "'c.ply': the vertices have no property z");
  EXPECT_EQ(message_of(header + "property float z\nend_header\n1 2 3\n4 5"), "'c.ply' is truncated: it ends in vertex 2 of 2");
  EXPECT_EQ(message_of(header + "property float z\nend_header\n1 2 3\n4 five 6\n"),
            "'c.ply': 'five' in vertex 2 is not a number");
  EXPECT_EQ(message_of("ply\nformat ascii 1.0\nelement face 1\nend_header\n"), "'c.ply' has no vertex element");
  EXPECT_EQ(message_of("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n"),
            "'c.ply': unknown type 'quad' in 'property quad x'");
}

// Found by fuzz/fuzz_ply.cpp: an element without properties before the vertices, with a count of
// 10^18, was read past row by row, reading nothing, for ever.
TEST(Ply, AnElementWithoutPropertiesAndAHugeCountIsPassedAtOnce) {
  const std::string tail = "element vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const PointCloud ascii = read("ply\nformat ascii 1.0\nelement marker 555555555555555555\n" + tail + "1 2 3\n4 5 6\n");
  EXPECT_EQ(ascii.xyz, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  const PointCloud binary =
      read("ply\nformat binary_little_endian 1.0\nelement marker 999999999999999999\n" + tail + le(1.0f) + le(2.0f) +
           le(3.0f) + le(4.0f) + le(5.0f) + le(6.0f));
  EXPECT_EQ(binary.xyz, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  // With a property, every row takes at least a byte: the count runs into the end of the file.
  EXPECT_EQ(message_of("ply\nformat ascii 1.0\nelement marker 555555555555555555\nproperty uchar m\n" + tail + "1\n"),
            "'c.ply' is truncated: it ends in marker 2 of 555555555555555555");
}

}  // namespace
}  // namespace mctstereo
