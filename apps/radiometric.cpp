#include "radiometric.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <initializer_list>
#include <numbers>
#include <random>
#include <stdexcept>
#include <system_error>

namespace mctstereo::app {

namespace {


// Shortest form that reads back as the same double: 0.75, 2, 1e-05.
std::string shortest(double value) {
  if (value == 0.0) return "0";  // not "-0"
  std::array<char, 32> text{};
  const auto [end, error] = std::to_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc{}) return "?";
  return std::string(text.data(), end);
}

// Rounded half away from zero (std::round) and clamped to a byte. The value is never NaN: amounts
// are checked to be finite first, and infinities clamp.
std::uint8_t to_byte(double value) { return static_cast<std::uint8_t>(std::clamp(std::round(value), 0.0, 255.0)); }

void check_image(const std::uint8_t* pixels, int width, int height, std::ptrdiff_t stride, int channels) {
  const std::string where = "apply_radiometric: ";
  if (width < 0 || height < 0)
    throw std::invalid_argument(where + "image size " + std::to_string(width) + "x" + std::to_string(height) +
                                " is negative");
  if (channels != 1 && channels != 3)
    throw std::invalid_argument(where + "channels must be 1 or 3, got " + std::to_string(channels));
  const std::ptrdiff_t row_bytes = static_cast<std::ptrdiff_t>(width) * channels;
  if (stride < row_bytes)
    throw std::invalid_argument(where + "stride " + std::to_string(stride) + " is below width * channels = " +
                                std::to_string(row_bytes));
  if (pixels == nullptr && width > 0 && height > 0)
    throw std::invalid_argument(where + "pixels are null for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " image");
}

void check_amount(const RadiometricChange& change) {
  const double a = change.amount;
  const char* rule = nullptr;
  switch (change.kind) {
    case RadiometricKind::Identity: return;
    case RadiometricKind::Gain: rule = std::isfinite(a) && a > 0 ? nullptr : "the factor must be finite and > 0"; break;
    case RadiometricKind::Bias: rule = std::isfinite(a) ? nullptr : "the offset must be finite"; break;
    case RadiometricKind::Gamma:
      rule = std::isfinite(a) && a > 0 ? nullptr : "the exponent must be finite and > 0";
      break;
    case RadiometricKind::Vignetting: rule = a >= 0 && a <= 1 ? nullptr : "the falloff must be in [0, 1]"; break;
    case RadiometricKind::Noise:
      rule = std::isfinite(a) && a >= 0 ? nullptr : "the standard deviation must be finite and >= 0";
      break;
    default:
      throw std::invalid_argument("apply_radiometric: unknown kind " +
                                  std::to_string(static_cast<int>(change.kind)));
  }
  if (rule != nullptr)
    throw std::invalid_argument(std::string("apply_radiometric: ") + radiometric_kind_name(change.kind) + " " + shortest(a) +
                                " is out of range: " + rule);
}

// Standard normal values from std::mt19937 by Box-Muller, both values of each pair used in turn.
// Written out so that the sequence for a seed is the same with every standard library.
class NormalSequence {
 public:
  explicit NormalSequence(std::uint32_t seed) : engine_(seed) {}

  double next() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = uniform();
    const double u2 = uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * std::numbers::pi * u2;
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }

 private:
  // (k + 0.5) / 2^32 lies strictly inside (0, 1), so log(u1) is finite; exact in a double.
  double uniform() { return (static_cast<double>(engine_()) + 0.5) * 0x1p-32; }

  std::mt19937 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

// Gain, bias and gamma map each value alone: one table of the 256 results.
std::array<std::uint8_t, 256> value_table(const RadiometricChange& change) {
  std::array<std::uint8_t, 256> table{};
  for (int v = 0; v < 256; ++v) {
    const double value = v;
    switch (change.kind) {
      case RadiometricKind::Gain: table[v] = to_byte(value * change.amount); break;
      case RadiometricKind::Bias: table[v] = to_byte(value + change.amount); break;
      case RadiometricKind::Gamma: table[v] = to_byte(255.0 * std::pow(value / 255.0, change.amount)); break;
      default: table[v] = static_cast<std::uint8_t>(v); break;
    }
  }
  return table;
}

}  // namespace

std::string RadiometricChange::label() const {
  if (kind == RadiometricKind::Identity) return "none";
  const std::string sign = kind == RadiometricKind::Bias && amount > 0 ? "+" : "";
  return std::string(radiometric_kind_name(kind)) + " " + sign + shortest(amount);
}

std::vector<RadiometricChange> exposure_study_steps() {
  std::vector<RadiometricChange> steps{{RadiometricKind::Identity, 0.0}};
  const auto add = [&steps](RadiometricKind kind, std::initializer_list<double> amounts) {
    for (double amount : amounts) steps.push_back({kind, amount});
  };
  add(RadiometricKind::Gain, {0.5, 0.75, 1.5, 2.0});
  add(RadiometricKind::Bias, {-40.0, -20.0, 20.0, 40.0});
  add(RadiometricKind::Gamma, {0.5, 0.75, 1.5, 2.0});
  add(RadiometricKind::Vignetting, {0.25, 0.5});
  add(RadiometricKind::Noise, {4.0, 8.0});
  return steps;
}

void apply_radiometric(const RadiometricChange& change, std::uint8_t* pixels, int width, int height,
                       std::ptrdiff_t stride, int channels, std::uint32_t seed) {
  check_image(pixels, width, height, stride, channels);
  check_amount(change);
  if (width == 0 || height == 0) return;
  const std::ptrdiff_t row_values = static_cast<std::ptrdiff_t>(width) * channels;

  switch (change.kind) {
    case RadiometricKind::Identity: return;
    case RadiometricKind::Gain:
    case RadiometricKind::Bias:
    case RadiometricKind::Gamma: {
      const auto table = value_table(change);
      for (int y = 0; y < height; ++y) {
        std::uint8_t* row = pixels + y * stride;
        for (std::ptrdiff_t i = 0; i < row_values; ++i) row[i] = table[row[i]];
      }
      return;
    }
    case RadiometricKind::Vignetting: {
      const double cx = (width - 1) / 2.0;
      const double cy = (height - 1) / 2.0;
      // r^2 / r_corner^2 rather than (r / r_corner)^2: no square roots, and exactly 1 at the corners.
      const double corner_squared = cx * cx + cy * cy;
      for (int y = 0; y < height; ++y) {
        std::uint8_t* row = pixels + y * stride;
        const double dy = y - cy;
        for (int x = 0; x < width; ++x) {
          const double dx = x - cx;
          const double factor =
              corner_squared > 0 ? 1.0 - change.amount * (dx * dx + dy * dy) / corner_squared : 1.0;
          std::uint8_t* value = row + static_cast<std::ptrdiff_t>(x) * channels;
          for (int c = 0; c < channels; ++c) value[c] = to_byte(value[c] * factor);
        }
      }
      return;
    }
    case RadiometricKind::Noise: {
      NormalSequence normal(seed);
      for (int y = 0; y < height; ++y) {
        std::uint8_t* row = pixels + y * stride;
        for (std::ptrdiff_t i = 0; i < row_values; ++i) row[i] = to_byte(row[i] + change.amount * normal.next());
      }
      return;
    }
  }
}

const char* radiometric_kind_name(RadiometricKind kind) {
  switch (kind) {
    case RadiometricKind::Identity: return "none";
    case RadiometricKind::Gain: return "gain";
    case RadiometricKind::Bias: return "bias";
    case RadiometricKind::Gamma: return "gamma";
    case RadiometricKind::Vignetting: return "vignetting";
    case RadiometricKind::Noise: return "noise";
  }
  return "unknown kind";
}

}  // namespace mctstereo::app
