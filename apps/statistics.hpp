// Order statistics of frame times.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace mctstereo::app {

/// The nearest-rank percentile p (0 < p <= 100) of `values`: the smallest value with at least p %
/// of the values at or below it. 0 for no values.
inline double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const double rank = std::ceil(p / 100.0 * static_cast<double>(values.size()));
  const std::size_t index = static_cast<std::size_t>(std::clamp(rank, 1.0, static_cast<double>(values.size()))) - 1;
  return values[index];
}

/// The median; the mean of the two middle values for an even count.
inline double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const std::size_t n = values.size();
  std::nth_element(values.begin(), values.begin() + n / 2, values.end());
  const double upper = values[n / 2];
  if (n % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + n / 2);
  return 0.5 * (lower + upper);
}

}  // namespace mctstereo::app
