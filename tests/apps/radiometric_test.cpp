// The radiometric changes of the exposure study, on pixels with known results.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "radiometric.hpp"

namespace mctstereo::app {
namespace {

using Bytes = std::vector<std::uint8_t>;

// Applies `change` to a copy of a contiguous width x height image and returns the copy.
Bytes applied(const RadiometricChange& change, Bytes pixels, int width, int height, int channels = 1,
              std::uint32_t seed = 1) {
  apply_radiometric(change, pixels.data(), width, height, static_cast<std::ptrdiff_t>(width) * channels, channels,
                    seed);
  return pixels;
}

// One row of values through a value-by-value change.
Bytes applied_to_values(RadiometricKind kind, double amount, const Bytes& values) {
  return applied({kind, amount}, values, static_cast<int>(values.size()), 1);
}

// The documented noise sequence, written out again: Box-Muller on std::mt19937(seed).
std::vector<double> documented_normals(std::uint32_t seed, int count) {
  std::mt19937 engine(seed);
  std::vector<double> normals;
  while (static_cast<int>(normals.size()) < count) {
    const double u1 = (static_cast<double>(engine()) + 0.5) / 4294967296.0;
    const double u2 = (static_cast<double>(engine()) + 0.5) / 4294967296.0;
    const double radius = std::sqrt(-2.0 * std::log(u1));
    normals.push_back(radius * std::cos(2.0 * std::numbers::pi * u2));
    normals.push_back(radius * std::sin(2.0 * std::numbers::pi * u2));
  }
  normals.resize(count);
  return normals;
}

// Runs `call` and returns the message of the std::invalid_argument it must throw.
template <typename Call>
std::string invalid_argument_message(Call call) {
  try {
    call();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  ADD_FAILURE() << "no std::invalid_argument";
  return {};
}

TEST(Radiometric, GainRoundsHalfAwayFromZeroAndClamps) {
  // 1.5 -> 2, 2.5 -> 3, 127.5 -> 128: halves go up, never to the even neighbour.
  EXPECT_EQ(applied_to_values(RadiometricKind::Gain, 0.5, {0, 1, 3, 5, 254, 255}), (Bytes{0, 1, 2, 3, 127, 128}));
  EXPECT_EQ(applied_to_values(RadiometricKind::Gain, 0.75, {2, 10, 200}), (Bytes{2, 8, 150}));  // 1.5, 7.5, 150
  EXPECT_EQ(applied_to_values(RadiometricKind::Gain, 1.5, {1, 170, 171}), (Bytes{2, 255, 255}));  // 1.5, 255, 256.5
  EXPECT_EQ(applied_to_values(RadiometricKind::Gain, 2.0, {0, 100, 127, 128, 200}), (Bytes{0, 200, 254, 255, 255}));
}

TEST(Radiometric, BiasAddsGreyLevelsAndClamps) {
  EXPECT_EQ(applied_to_values(RadiometricKind::Bias, -40.0, {0, 10, 40, 41, 255}), (Bytes{0, 0, 0, 1, 215}));
  EXPECT_EQ(applied_to_values(RadiometricKind::Bias, 20.0, {0, 100, 235, 236, 255}), (Bytes{20, 120, 255, 255, 255}));
  // A fractional offset rounds like the others: 10.5 -> 11, 100.5 -> 101.
  EXPECT_EQ(applied_to_values(RadiometricKind::Bias, 0.5, {10, 100}), (Bytes{11, 101}));
}

TEST(Radiometric, GammaFollowsThePowerCurveAndKeepsBlackAndWhite) {
  // 255 (128/255)^2 = 128^2 / 255 = 64.25; 200^2 / 255 = 156.86; 1 / 255 = 0.004.
  EXPECT_EQ(applied_to_values(RadiometricKind::Gamma, 2.0, {0, 1, 128, 200, 255}), (Bytes{0, 0, 64, 157, 255}));
  // 255 sqrt(v / 255) = sqrt(255 v): sqrt(255) = 15.97, sqrt(1020) = 31.94, sqrt(16320) = 127.75.
  EXPECT_EQ(applied_to_values(RadiometricKind::Gamma, 0.5, {0, 1, 4, 64, 255}), (Bytes{0, 16, 32, 128, 255}));
  // 255 (100/255)^1.5 = 62.62; 255 (100/255)^0.75 = 126.37.
  EXPECT_EQ(applied_to_values(RadiometricKind::Gamma, 1.5, {100}), (Bytes{63}));
  EXPECT_EQ(applied_to_values(RadiometricKind::Gamma, 0.75, {100}), (Bytes{126}));
}

TEST(Radiometric, VignettingDarkensWithTheSquaredDistanceFromTheCentre) {
  // 5 x 3: centre (2, 1), r_corner^2 = 5, factor 1 - 0.5 r^2 / 5.
  const Bytes flat(15, 200);
  const Bytes expected{100, 160, 180, 160, 100,  // corners 0.5, r^2 = 2: 0.8, r^2 = 1: 0.9
                       120, 180, 200, 180, 120,  // r^2 = 4: 0.6, 0.9, the centre unchanged
                       100, 160, 180, 160, 100};
  EXPECT_EQ(applied({RadiometricKind::Vignetting, 0.5}, flat, 5, 3), expected);
  // Corners at 1 - amount: 255 * 0.75 = 191.25.
  const Bytes corners = applied({RadiometricKind::Vignetting, 0.25}, Bytes(15, 255), 5, 3);
  EXPECT_EQ(corners[0], 191);
  EXPECT_EQ(corners[4], 191);
  EXPECT_EQ(corners[10], 191);
  EXPECT_EQ(corners[14], 191);
  EXPECT_EQ(corners[7], 255);
}

TEST(Radiometric, VignettingOfTinyImages) {
  // 2 x 2: every pixel is a corner; 201 * 0.5 = 100.5 rounds up.
  EXPECT_EQ(applied({RadiometricKind::Vignetting, 0.5}, Bytes(4, 201), 2, 2), Bytes(4, 101));
  // One row: the ends are the corners. Centre (2, 0), r_corner^2 = 4: factors 0.5, 0.875, 1.
  EXPECT_EQ(applied({RadiometricKind::Vignetting, 0.5}, Bytes(5, 200), 5, 1), (Bytes{100, 175, 200, 175, 100}));
  // 1 x 1 has no distance to the corner: unchanged, even at full falloff.
  EXPECT_EQ(applied({RadiometricKind::Vignetting, 1.0}, Bytes{200}, 1, 1), Bytes{200});
  // Full falloff blackens the corners.
  EXPECT_EQ(applied({RadiometricKind::Vignetting, 1.0}, Bytes(4, 255), 2, 2), Bytes(4, 0));
}

TEST(Radiometric, NoiseIsTheDocumentedSequenceAndReproducible) {
  const RadiometricChange noise{RadiometricKind::Noise, 8.0};
  const Bytes flat(8 * 4, 128);
  const Bytes first = applied(noise, flat, 8, 4, 1, 7);
  EXPECT_EQ(applied(noise, flat, 8, 4, 1, 7), first);
  EXPECT_NE(applied(noise, flat, 8, 4, 1, 8), first);
  const std::vector<double> normals = documented_normals(7, 32);
  for (int i = 0; i < 32; ++i) EXPECT_EQ(first[i], static_cast<std::uint8_t>(std::round(128.0 + 8.0 * normals[i])));
  // No noise, no change (the generator still runs).
  EXPECT_EQ(applied({RadiometricKind::Noise, 0.0}, flat, 8, 4, 1, 7), flat);
}

TEST(Radiometric, NoiseHasZeroMeanAndTheRequestedDeviation) {
  for (double sigma : {4.0, 8.0}) {
    // Flat grey 128: +-6.8 sigma at most, so nothing clamps.
    const Bytes noisy = applied({RadiometricKind::Noise, sigma}, Bytes(256 * 256, 128), 256, 256, 1, 42);
    double sum = 0.0;
    double sum_squares = 0.0;
    for (std::uint8_t v : noisy) {
      const double added = v - 128.0;
      sum += added;
      sum_squares += added * added;
    }
    const double n = static_cast<double>(noisy.size());
    const double mean = sum / n;
    const double deviation = std::sqrt(sum_squares / n - mean * mean);
    EXPECT_NEAR(mean, 0.0, 0.2) << "sigma " << sigma;
    EXPECT_NEAR(deviation, sigma, 0.05 * sigma) << "sigma " << sigma;
  }
}

TEST(Radiometric, NoiseClampsAtBlackAndWhite) {
  const Bytes black = applied({RadiometricKind::Noise, 8.0}, Bytes(64 * 64, 0), 64, 64, 1, 3);
  const Bytes white = applied({RadiometricKind::Noise, 8.0}, Bytes(64 * 64, 255), 64, 64, 1, 3);
  // The same draws: wherever black went up, white would have gone above 255 and stays there.
  int raised = 0;
  for (std::size_t i = 0; i < black.size(); ++i) {
    if (black[i] > 0) {
      ++raised;
      EXPECT_EQ(white[i], 255);
    }
  }
  EXPECT_GT(raised, 1000);  // about half of 4096
  EXPECT_LT(raised, 3000);
}

TEST(Radiometric, ThreeChannelsChangeAlikeAndDrawNoisePerChannel) {
  // Gain 1.5 of (10, 100, 200): 15, 150, 300 -> 255.
  EXPECT_EQ(applied({RadiometricKind::Gain, 1.5}, {10, 100, 200}, 1, 1, 3), (Bytes{15, 150, 255}));
  // 3 x 3 RGB vignetting: corners times 0.5 in every channel, the centre unchanged.
  Bytes rgb;
  for (int i = 0; i < 9; ++i) rgb.insert(rgb.end(), {40, 120, 201});
  const Bytes vignetted = applied({RadiometricKind::Vignetting, 0.5}, rgb, 3, 3, 3);
  EXPECT_EQ(Bytes(vignetted.begin(), vignetted.begin() + 3), (Bytes{20, 60, 101}));  // (0, 0)
  EXPECT_EQ(Bytes(vignetted.begin() + 12, vignetted.begin() + 15), (Bytes{40, 120, 201}));  // (1, 1)
  EXPECT_EQ(Bytes(vignetted.begin() + 24, vignetted.begin() + 27), (Bytes{20, 60, 101}));  // (2, 2)
  // (1, 0): r^2 = 1 of r_corner^2 = 2, factor 0.75: 30, 90, 150.75.
  EXPECT_EQ(Bytes(vignetted.begin() + 3, vignetted.begin() + 6), (Bytes{30, 90, 151}));
  // Noise: each channel of a pixel its own draw, in order.
  const Bytes noisy = applied({RadiometricKind::Noise, 8.0}, Bytes(2 * 3, 128), 2, 1, 3, 5);
  const std::vector<double> normals = documented_normals(5, 6);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(noisy[i], static_cast<std::uint8_t>(std::round(128.0 + 8.0 * normals[i])));
  EXPECT_FALSE(noisy[0] == noisy[1] && noisy[1] == noisy[2]);
}

TEST(Radiometric, StridePaddingIsUntouchedAndDoesNotShiftTheResult) {
  constexpr int kWidth = 5, kHeight = 4, kChannels = 3, kStride = kWidth * kChannels + 3;
  constexpr std::uint8_t kPadding = 77;
  Bytes contiguous(kWidth * kHeight * kChannels);
  for (std::size_t i = 0; i < contiguous.size(); ++i) contiguous[i] = static_cast<std::uint8_t>(i * 13 % 256);
  for (const RadiometricChange& change : exposure_study_steps()) {
    Bytes padded(kStride * kHeight, kPadding);
    for (int y = 0; y < kHeight; ++y)
      std::copy_n(contiguous.begin() + y * kWidth * kChannels, kWidth * kChannels, padded.begin() + y * kStride);
    apply_radiometric(change, padded.data(), kWidth, kHeight, kStride, kChannels, 11);
    const Bytes expected = applied(change, contiguous, kWidth, kHeight, kChannels, 11);
    for (int y = 0; y < kHeight; ++y) {
      for (int i = 0; i < kStride; ++i) {
        const std::uint8_t want = i < kWidth * kChannels ? expected[y * kWidth * kChannels + i] : kPadding;
        ASSERT_EQ(padded[y * kStride + i], want) << change.label() << " row " << y << " byte " << i;
      }
    }
  }
}

TEST(Radiometric, IdentityAndEmptyImagesChangeNothing) {
  const Bytes values{0, 17, 128, 255};
  EXPECT_EQ(applied({RadiometricKind::Identity, 5.0}, values, 2, 2), values);
  // Nothing to change: no pixels needed.
  for (const RadiometricChange& change : exposure_study_steps()) {
    EXPECT_NO_THROW(apply_radiometric(change, nullptr, 0, 0, 0, 1, 1)) << change.label();
    EXPECT_NO_THROW(apply_radiometric(change, nullptr, 0, 7, 0, 3, 1)) << change.label();
  }
}

TEST(Radiometric, StudyStepsStartWithTheIdentityAndCoverEveryKind) {
  const std::vector<RadiometricChange> steps = exposure_study_steps();
  ASSERT_FALSE(steps.empty());
  EXPECT_EQ(steps.front().kind, RadiometricKind::Identity);
  std::vector<std::string> labels;
  std::set<RadiometricKind> kinds;
  for (const RadiometricChange& step : steps) {
    labels.push_back(step.label());
    kinds.insert(step.kind);
  }
  const std::vector<std::string> expected{
      "none",          "gain 0.5",       "gain 0.75",      "gain 1.5",  "gain 2",   "bias -40",
      "bias -20",      "bias +20",       "bias +40",       "gamma 0.5", "gamma 0.75", "gamma 1.5",
      "gamma 2",       "vignetting 0.25", "vignetting 0.5", "noise 4",   "noise 8"};
  EXPECT_EQ(labels, expected);
  EXPECT_EQ(std::set<std::string>(labels.begin(), labels.end()).size(), labels.size());
  EXPECT_EQ(kinds.size(), 6u);
  EXPECT_EQ(steps.at(7).amount, 20.0);
  EXPECT_EQ(steps.at(14).amount, 0.5);
}

TEST(Radiometric, LabelsWriteTheAmountShortest) {
  EXPECT_EQ((RadiometricChange{RadiometricKind::Identity, 3.0}.label()), "none");
  EXPECT_EQ((RadiometricChange{RadiometricKind::Bias, 0.0}.label()), "bias 0");
  EXPECT_EQ((RadiometricChange{RadiometricKind::Bias, -0.0}.label()), "bias 0");
  EXPECT_EQ((RadiometricChange{RadiometricKind::Bias, 12.5}.label()), "bias +12.5");
  EXPECT_EQ((RadiometricChange{RadiometricKind::Gain, 1.25}.label()), "gain 1.25");
  EXPECT_EQ((RadiometricChange{RadiometricKind::Noise, 0.1}.label()), "noise 0.1");
}

TEST(Radiometric, BadImagesAreRejectedByName) {
  Bytes pixels(64, 0);
  const RadiometricChange gain{RadiometricKind::Gain, 2.0};
  auto message = [&](int width, int height, std::ptrdiff_t stride, int channels, std::uint8_t* data) {
    return invalid_argument_message([&] { apply_radiometric(gain, data, width, height, stride, channels, 1); });
  };
  EXPECT_NE(message(-1, 2, 4, 1, pixels.data()).find("-1x2"), std::string::npos);
  EXPECT_NE(message(2, -3, 4, 1, pixels.data()).find("2x-3"), std::string::npos);
  EXPECT_NE(message(2, 2, 8, 2, pixels.data()).find("channels must be 1 or 3, got 2"), std::string::npos);
  EXPECT_NE(message(2, 2, 8, 4, pixels.data()).find("got 4"), std::string::npos);
  EXPECT_NE(message(4, 2, 11, 3, pixels.data()).find("stride 11 is below width * channels = 12"),
            std::string::npos);
  EXPECT_NE(message(2, 2, 2, 1, nullptr).find("null"), std::string::npos);
  // The image is left as it was.
  EXPECT_EQ(pixels, Bytes(64, 0));
}

TEST(Radiometric, AmountsOutOfRangeAreRejectedWithKindAndAmount) {
  Bytes pixels(4, 100);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  struct Case {
    RadiometricChange change;
    std::string names;
  };
  const std::vector<Case> cases{
      {{RadiometricKind::Gain, 0.0}, "gain 0"},          {{RadiometricKind::Gain, -1.0}, "gain -1"},
      {{RadiometricKind::Gain, inf}, "gain inf"},        {{RadiometricKind::Gain, nan}, "gain nan"},
      {{RadiometricKind::Bias, -inf}, "bias -inf"},      {{RadiometricKind::Gamma, 0.0}, "gamma 0"},
      {{RadiometricKind::Gamma, -2.0}, "gamma -2"},      {{RadiometricKind::Vignetting, -0.1}, "vignetting -0.1"},
      {{RadiometricKind::Vignetting, 1.5}, "vignetting 1.5"}, {{RadiometricKind::Vignetting, nan}, "vignetting nan"},
      {{RadiometricKind::Noise, -1.0}, "noise -1"},      {{RadiometricKind::Noise, inf}, "noise inf"},
  };
  for (const Case& c : cases) {
    const std::string what =
        invalid_argument_message([&] { apply_radiometric(c.change, pixels.data(), 2, 2, 2, 1, 1); });
    EXPECT_NE(what.find(c.names), std::string::npos) << what;
  }
  EXPECT_EQ(pixels, Bytes(4, 100));
  // The edges of the ranges are fine.
  EXPECT_NO_THROW(apply_radiometric({RadiometricKind::Vignetting, 0.0}, pixels.data(), 2, 2, 2, 1, 1));
  EXPECT_NO_THROW(apply_radiometric({RadiometricKind::Vignetting, 1.0}, pixels.data(), 2, 2, 2, 1, 1));
  EXPECT_NO_THROW(apply_radiometric({RadiometricKind::Noise, 0.0}, pixels.data(), 2, 2, 2, 1, 1));
  const std::string unknown = invalid_argument_message(
      [&] { apply_radiometric({static_cast<RadiometricKind>(99), 1.0}, pixels.data(), 2, 2, 2, 1, 1); });
  EXPECT_NE(unknown.find("unknown kind 99"), std::string::npos) << unknown;
}

}  // namespace
}  // namespace mctstereo::app
