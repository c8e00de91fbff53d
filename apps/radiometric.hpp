// Changes of exposure and illumination applied to one image of a pair (thesis 6.3.4): the
// robustness study of `mctstereo eval --radiometric`. Plain functions on 8-bit pixels, no OpenCV.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mctstereo::app {

enum class RadiometricKind { Identity, Gain, Bias, Gamma, Vignetting, Noise };

/// One change. `amount` is, by kind: Gain the factor (v * g); Bias grey levels added (v + b);
/// Gamma the exponent (255 (v / 255)^gamma); Vignetting the falloff at the corners (factor
/// 1 - amount (r / r_corner)^2, r the distance from the image centre); Noise the standard
/// deviation of added Gaussian noise in grey levels. Results are rounded half away from zero
/// and clamped to 0..255. Identity ignores `amount`.
///
/// Exactly, for a value v of one channel at pixel (x, y) of a w x h image, round = half away from
/// zero, clamp = to 0..255:
///   Gain        v' = clamp(round(v * g)), g > 0
///   Bias        v' = clamp(round(v + b))  (v + b for a whole b)
///   Gamma       v' = clamp(round(255 * pow(v / 255, gamma))), gamma > 0
///   Vignetting  c = ((w - 1) / 2, (h - 1) / 2), r = |(x, y) - c|, r_corner = |c| (the distance
///               from the centre to pixel (0, 0), so all four corners get the full falloff);
///               factor = 1 - amount * r^2 / r_corner^2 (1 for a 1 x 1 image), amount in [0, 1];
///               v' = clamp(round(v * factor))
///   Noise       v' = clamp(round(v + sigma * n)), sigma >= 0, n the next value of a standard normal
///               sequence, one per value in row-major order (channels of a pixel in turn, each its
///               own draw): Box-Muller on std::mt19937(seed), u = (k + 0.5) / 2^32 from each 32-bit
///               output k, z0 = sqrt(-2 ln u1) cos(2 pi u2), z1 = sqrt(-2 ln u1) sin(2 pi u2), used
///               in that order. Written out rather than std::normal_distribution, whose sequence
///               differs between standard libraries.
/// Every amount must be finite.
struct RadiometricChange {
  RadiometricKind kind = RadiometricKind::Identity;
  double amount = 0.0;
  /// "none", "gain 0.5", "bias -40", "bias +20", "gamma 2", "vignetting 0.5", "noise 8": the amount
  /// in its shortest exact form, a bias above 0 with its sign.
  std::string label() const;
};

/// "none", "gain", "bias", "gamma", "vignetting", "noise".
const char* radiometric_kind_name(RadiometricKind kind);

/// The steps of the study: the identity first, then each kind over a few amounts: gain 0.5, 0.75,
/// 1.5, 2; bias -40, -20, +20, +40; gamma 0.5, 0.75, 1.5, 2; vignetting 0.25, 0.5 (corners at 75 %
/// and 50 % of their brightness); noise 4, 8.
std::vector<RadiometricChange> exposure_study_steps();

/// Applies `change` in place to an 8-bit image of `channels` interleaved channels (1 or 3, each
/// channel alike), rows `stride` bytes apart; bytes past width * channels in a row are left as they
/// are. Noise is drawn from a generator seeded by `seed`, so a run is reproducible.
/// Throws std::invalid_argument for a bad image (negative size, channels not 1 or 3, stride below
/// width * channels, null pixels for a non-empty image) or an amount out of range for its kind.
void apply_radiometric(const RadiometricChange& change, std::uint8_t* pixels, int width, int height,
                       std::ptrdiff_t stride, int channels, std::uint32_t seed);

}  // namespace mctstereo::app
