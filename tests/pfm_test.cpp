// PFM files: the bytes the program writes, both byte orders read back, and damaged files refused
// with a message naming them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/pfm.hpp"

namespace mctstereo {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

std::string text_of(const std::vector<std::uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

std::string float_bytes(float v, bool little_endian) {
  std::uint32_t bits;
  std::memcpy(&bits, &v, 4);
  std::string s(4, '\0');
  for (int b = 0; b < 4; ++b) s[little_endian ? b : 3 - b] = static_cast<char>(bits >> (8 * b));
  return s;
}

std::string message_of(const std::string& bytes) {
  try {
    decode_pfm(bytes, "'x.pfm'");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(Pfm, EncodesBottomRowFirstLittleEndianWithInfWhereNotFinite) {
  const std::vector<float> values = {1.5f, kNaN, -2.0f,  //
                                     3.25f, -kInf, 0.0f};
  const std::string bytes = text_of(encode_pfm({values.data(), 3, 2, 3}));
  std::string expected = "Pf\n3 2\n-1.0\n";
  for (float v : {3.25f, kInf, 0.0f, 1.5f, kInf, -2.0f}) expected += float_bytes(v, true);
  EXPECT_EQ(bytes, expected);
}

TEST(Pfm, EncodesAViewWithARowStride) {
  const std::vector<float> padded = {1, 2, 99, 3, 4, 99};
  const std::vector<float> packed = {1, 2, 3, 4};
  EXPECT_EQ(encode_pfm({padded.data(), 2, 2, 3}), encode_pfm({packed.data(), 2, 2, 2}));
}

TEST(Pfm, DecodesWhatItEncodesAndEitherByteOrder) {
  const std::vector<float> values = {1.5f, kInf, -2.0f, 3.25f, 7.0f, 0.125f};
  const FloatMap map = decode_pfm(text_of(encode_pfm({values.data(), 3, 2, 3})));
  ASSERT_EQ(map.width, 3);
  ASSERT_EQ(map.height, 2);
  EXPECT_EQ(map.values, values);
  // Big-endian (positive scale), header fields split by any whitespace.
  std::string big = "Pf 2  1\t4.0\n";
  for (float v : {10.0f, -0.5f}) big += float_bytes(v, false);
  EXPECT_EQ(decode_pfm(big).values, (std::vector<float>{10.0f, -0.5f}));
}

TEST(Pfm, FirstSampleMayLookLikeWhitespace) {
  std::string bytes = "Pf\n1 1\n-1.0\n";
  float v;
  const std::uint32_t bits = 0x0A0A0A0Au;  // a float whose bytes are all '\n'
  std::memcpy(&v, &bits, 4);
  bytes += float_bytes(v, true);
  const FloatMap map = decode_pfm(bytes);
  std::uint32_t read;
  std::memcpy(&read, map.values.data(), 4);
  EXPECT_EQ(read, bits);
}

TEST(Pfm, DamagedFilesAreRefusedByName) {
  EXPECT_EQ(message_of("P5\n1 1\n255\n"), "'x.pfm' is not a PFM file: it must start with 'Pf'");
  EXPECT_NE(message_of("PF\n1 1\n-1.0\n" + std::string(12, '\0')).find("'x.pfm' is a colour PFM (PF)"),
            std::string::npos);
  EXPECT_NE(message_of("Pf\n96 sixty-four\n-1.0\n").find("bad PFM header 'Pf 96 sixty-four -1.0'"), std::string::npos);
  EXPECT_NE(message_of("Pf\n2 2\n0\n").find("bad PFM header"), std::string::npos);  // a zero scale
  EXPECT_NE(message_of("Pf\n70000 1\n-1\n").find("PFM header 'Pf 70000 1 -1': 70000x1 is too large (at most 32768"),
            std::string::npos);
  EXPECT_EQ(message_of("Pf\n2 2\n-1.0"), "'x.pfm': bad PFM header: no line break after the scale");
  EXPECT_EQ(message_of("Pf\n2 2\n-1.0\n" + std::string(15, '\0')),
            "'x.pfm': truncated PFM: 2x2 needs 16 bytes of samples, the file has 15");
}

TEST(Pfm, StreamsWriteAndReadTheSameBytes) {
  const std::vector<float> values = {1, 2, 3, 4, 5, 6};
  std::stringstream stream;
  write_pfm(stream, {values.data(), 2, 3, 2});
  EXPECT_EQ(stream.str(), text_of(encode_pfm({values.data(), 2, 3, 2})));
  const FloatMap map = read_pfm(stream);
  EXPECT_EQ(map.values, values);
  EXPECT_EQ(map.view().at(1, 2), 6.0f);
}

}  // namespace
}  // namespace mctstereo
