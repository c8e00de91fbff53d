// cpu::census_transform equals the reference bit for bit, pad columns included, for every window,
// CT and MCT with both kernels, on every SIMD target and with 1 and 2 threads.
#include <omp.h>

#include "test_util.hpp"

namespace mctstereo::test {
namespace {

using detail::CensusCodes;
using detail::CensusConfig;
using detail::kCodePad;

// First difference of two code sets over x in [-kCodePad, w + kCodePad), or empty when equal.
std::string first_code_difference(const CensusCodes& a, const CensusCodes& b) {
  for (int k = 0; k < a.words; ++k) {
    const auto& pa = a.plane[k];
    const auto& pb = b.plane[k];
    for (int y = 0; y < pa.height(); ++y)
      for (int x = -kCodePad; x < pa.width() + kCodePad; ++x)
        if (pa.at(x, y) != pb.at(x, y))
          return "word " + std::to_string(k) + " (" + std::to_string(x) + ", " + std::to_string(y) +
                 "): " + std::to_string(pa.at(x, y)) + " vs " + std::to_string(pb.at(x, y));
  }
  return {};
}

void expect_equal_to_reference(const Plane<std::uint8_t>& image, const std::string& what) {
  const int w = image.width(), h = image.height();
  for (const CensusConfig& config : all_census_configs()) {
    CensusCodes expected = code_planes(w, h, config.window);
    detail::reference::census_transform(image, config, expected);
    for_each_target_and_threads([&](const std::string& label) {
      CensusCodes got = code_planes(w, h, config.window);
      detail::cpu::census_transform(image, config, got);
      EXPECT_EQ(first_code_difference(got, expected), "")
          << what << " " << w << "x" << h << " " << census_config_name(config) << " " << label;
    });
  }
}

TEST(CpuCensus, EqualsReferenceOnNoiseAtAwkwardSizes) {
  std::uint32_t seed = 7;
  for (auto [w, h] : awkward_sizes()) expect_equal_to_reference(random_image(w, h, seed++), "noise");
}

TEST(CpuCensus, EqualsReferenceWithTiesAndPaddedInput) {
  std::uint32_t seed = 70;
  for (auto [w, h] : {std::pair{97, 13}, std::pair{64, 5}, std::pair{5, 6}})
    expect_equal_to_reference(few_levels_image(w, h, seed++), "four levels");
  // Input rows with pad columns of other values, which must not be read as pixels.
  expect_equal_to_reference(random_image(131, 9, 77, 16), "padded input");
}

TEST(CpuCensus, PadColumnsRepeatTheEdgeCodes) {
  const Plane<std::uint8_t> image = random_texture(77, 6, 5);
  for (const CensusConfig& config : all_census_configs()) {
    for_each_target_and_threads([&](const std::string& label) {
      CensusCodes codes = code_planes(77, 6, config.window);
      detail::cpu::census_transform(image, config, codes);
      for (int k = 0; k < codes.words; ++k)
        for (int y = 0; y < 6; ++y)
          for (int i = 1; i <= kCodePad; ++i) {
            ASSERT_EQ(codes.plane[k].at(-i, y), codes.plane[k].at(0, y)) << census_config_name(config) << " " << label;
            ASSERT_EQ(codes.plane[k].at(76 + i, y), codes.plane[k].at(76, y))
                << census_config_name(config) << " " << label;
          }
    });
  }
}

TEST(CpuCensus, ThesisExampleOnEveryTarget) {
  // DESIGN.md section 2: the 5x5 window of the thesis, here in the middle of a wider image so that
  // the pixel is computed by a full vector on every target.
  constexpr std::uint8_t kWindow[5][5] = {{41, 154, 115, 211, 27}, {203, 67, 21, 137, 246}, {79, 167, 58, 255, 1},
                                          {135, 176, 233, 20, 198}, {42, 191, 39, 113, 209}};
  Plane<std::uint8_t> image(200, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) image.at(98 + x, y) = kWindow[y][x];
  auto centre_string = [&](const CensusConfig& config) {
    CensusCodes codes = code_planes(200, 5, config.window);
    detail::cpu::census_transform(image, config, codes);
    const int bits = config.window * config.window - 1;
    std::string s;
    for (int k = 0; k < codes.words; ++k) {
      const int in_word = k == codes.words - 1 ? bits - 32 * k : 32;
      for (int b = in_word - 1; b >= 0; --b) s += ((codes.plane[k].at(100, 2) >> b) & 1u) ? '1' : '0';
    }
    return s;
  };
  for_each_target_and_threads([&](const std::string& label) {
    EXPECT_EQ(centre_string({CensusKind::Census, 5, MeanKernel::Box}), "100010010000010001010100") << label;
    EXPECT_EQ(centre_string({CensusKind::Census, 3, MeanKernel::Box}), "01000001") << label;
    EXPECT_EQ(centre_string({CensusKind::ModifiedCensus, 5, MeanKernel::Box}), "101010110010010001010110") << label;
    EXPECT_EQ(centre_string({CensusKind::ModifiedCensus, 3, MeanKernel::Gaussian}), "11000001") << label;
  });
}

}  // namespace
}  // namespace mctstereo::test
