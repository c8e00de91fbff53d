// Synthetic scenes with exact ground truth: a random texture seen under a disparity field, plus
// sensor noise (synthetic_test.cpp, temporal_test.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <random>
#include <vector>

#include "mctstereo/image.hpp"
#include "test_util.hpp"

namespace mctstereo::test {

struct Scene {
  std::vector<std::uint8_t> left, right;
  std::vector<float> truth;  // left-view disparity
  int w, h;
  ImageView left_view() const { return {left.data(), w, h, w, PixelFormat::Gray8}; }
  ImageView right_view() const { return {right.data(), w, h, w, PixelFormat::Gray8}; }
};

// The right view is random texture; the left view samples it at x - d(x, y) (linear
// interpolation for fractional d) and both get Gaussian noise of the given sigma. The texture comes
// from `seed`, the noise from `noise_seed` (seed + 1 when 0): frames of one scene share the texture
// and differ in noise.
inline Scene make_scene(int w, int h, const std::function<double(int, int)>& disparity, double noise,
                        std::uint32_t seed, std::uint32_t noise_seed = 0) {
  Scene s{std::vector<std::uint8_t>(w * h), std::vector<std::uint8_t>(w * h), std::vector<float>(w * h), w, h};
  const Plane<std::uint8_t> texture = random_texture(w, h, seed);
  std::mt19937 rng(noise_seed != 0 ? noise_seed : seed + 1);
  std::normal_distribution<double> gauss(0.0, noise);
  auto noisy = [&](double v) { return static_cast<std::uint8_t>(std::clamp(std::lround(v + gauss(rng)), 0L, 255L)); };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double d = disparity(x, y);
      s.truth[y * w + x] = static_cast<float>(d);
      const double xs = x - d;
      const int x0 = static_cast<int>(std::floor(xs));
      const double t = xs - x0;
      const double a = texture.at(std::clamp(x0, 0, w - 1), y), b = texture.at(std::clamp(x0 + 1, 0, w - 1), y);
      s.left[y * w + x] = noisy(a + t * (b - a));
      s.right[y * w + x] = noisy(texture.at(x, y));
    }
  return s;
}

/// The pixels of a scene with a correspondence (x - d inside the right view), and of those the
/// bad ones: invalid in `disparity` or more than 1 px off.
struct CorrespondenceScore {
  long bad = 0, total = 0;
};
inline CorrespondenceScore score_correspondences(const Scene& s, MapView<const float> disparity) {
  CorrespondenceScore score;
  for (int y = 0; y < s.h; ++y)
    for (int x = 0; x < s.w; ++x) {
      const float d = s.truth[y * s.w + x];
      if (x - d < 0) continue;  // occluded: the left border band
      ++score.total;
      const float v = disparity.at(x, y);
      if (std::isnan(v) || std::fabs(v - d) > 1.0f) ++score.bad;
    }
  return score;
}

}  // namespace mctstereo::test
