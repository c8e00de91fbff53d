// Wall-clock laps of the drivers' stage times (Matcher::timings()).
#pragma once

#include <chrono>

namespace mctstereo::detail {

class Stopwatch {
 public:
  Stopwatch() : t0_(std::chrono::steady_clock::now()) {}
  /// Milliseconds since the last lap (or since it was made), and a new lap from now.
  double lap_ms() {
    const auto t1 = std::chrono::steady_clock::now();
    const double ms = std::chrono::duration<double, std::milli>(t1 - t0_).count();
    t0_ = t1;
    return ms;
  }

 private:
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace mctstereo::detail
