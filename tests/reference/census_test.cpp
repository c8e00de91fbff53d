// Known answers of the census transforms: the worked examples of the thesis (section 3.2),
// reproduced in DESIGN.md.
#include <bitset>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

constexpr std::uint8_t kThesisWindow[5][5] = {
    {41, 154, 115, 211, 27}, {203, 67, 21, 137, 246}, {79, 167, 58, 255, 1},
    {135, 176, 233, 20, 198}, {42, 191, 39, 113, 209}};

Plane<std::uint8_t> thesis_image() {
  Plane<std::uint8_t> img(5, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) img.at(x, y) = kThesisWindow[y][x];
  return img;
}

// The census string of the centre pixel (2, 2) as '0'/'1' characters, first neighbour first.
std::string centre_string(CensusKind kind, int window, MeanKernel kernel, bool cpu) {
  const Plane<std::uint8_t> img = thesis_image();
  detail::CensusCodes codes;
  codes.words = detail::census_words(window);
  for (int k = 0; k < codes.words; ++k) codes.plane[k].reset(5, 5, detail::kCodePad);
  const detail::CensusConfig config{kind, window, kernel};
  if (cpu)
    detail::cpu::census_transform(img, config, codes);
  else
    detail::reference::census_transform(img, config, codes);
  const int bits = window * window - 1;
  std::string s;
  for (int k = 0; k < codes.words; ++k) {
    const int in_word = k == codes.words - 1 ? bits - 32 * k : 32;
    const std::uint32_t w = codes.plane[k].at(2, 2);
    for (int b = in_word - 1; b >= 0; --b) s += ((w >> b) & 1u) ? '1' : '0';
  }
  return s;
}

class CensusKnownAnswer : public ::testing::TestWithParam<bool> {};

TEST_P(CensusKnownAnswer, Census5x5) {
  EXPECT_EQ(centre_string(CensusKind::Census, 5, MeanKernel::Box, GetParam()), "100010010000010001010100");
}

TEST_P(CensusKnownAnswer, Census3x3OfTheInnerWindow) {
  EXPECT_EQ(centre_string(CensusKind::Census, 3, MeanKernel::Box, GetParam()), "01000001");
}

TEST_P(CensusKnownAnswer, ModifiedCensus5x5WithTheMeanKernel) {
  // The 3x3 mean around the centre is 1134 / 9 = 126.
  EXPECT_EQ(centre_string(CensusKind::ModifiedCensus, 5, MeanKernel::Box, GetParam()), "101010110010010001010110");
}

TEST_P(CensusKnownAnswer, ModifiedCensusWithTheGaussianKernel) {
  // Gaussian 3x3 sum: 67 + 2*21 + 137 + 2*167 + 4*58 + 2*255 + 176 + 2*233 + 20 = 1984, mean 124.
  // The only neighbours whose order against 124 differs from 126 lie in [124, 126]: none here, so
  // the string equals the mean kernel's.
  EXPECT_EQ(centre_string(CensusKind::ModifiedCensus, 5, MeanKernel::Gaussian, GetParam()), "101010110010010001010110");
  // 3x3: neighbours 67 21 137 167 | 255 176 233 20 compared with 124.
  EXPECT_EQ(centre_string(CensusKind::ModifiedCensus, 3, MeanKernel::Gaussian, GetParam()), "11000001");
}

TEST_P(CensusKnownAnswer, NineByNineUsesThreeWordsWithClampedBorders) {
  // A 9x9 window around (2, 2) of a 5x5 image reads clamped coordinates: rows -2..6 map to
  // 0,0,0,1,2,3,4,4,4. Build the expected string directly from that rule.
  std::string expected;
  for (int j = -4; j <= 4; ++j)
    for (int i = -4; i <= 4; ++i) {
      if (i == 0 && j == 0) continue;
      const int x = std::clamp(2 + i, 0, 4), y = std::clamp(2 + j, 0, 4);
      expected += kThesisWindow[y][x] < kThesisWindow[2][2] ? '1' : '0';
    }
  ASSERT_EQ(expected.size(), 80u);
  EXPECT_EQ(centre_string(CensusKind::Census, 9, MeanKernel::Box, GetParam()), expected);
}

INSTANTIATE_TEST_SUITE_P(Backends, CensusKnownAnswer, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "cpu" : "reference"; });

}  // namespace
}  // namespace mctstereo::test
