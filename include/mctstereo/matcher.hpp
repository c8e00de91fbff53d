// mctstereo: the stereo matcher. Configured once per (size, parameters, backend), run per frame.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "mctstereo/image.hpp"
#include "mctstereo/params.hpp"

namespace mctstereo {

/// Where the pipeline runs.
enum class Backend {
  Reference,  ///< scalar, one plain loop per stage: the specification in code; single thread
  Cpu,        ///< SIMD (Highway, dispatched at run time) and OpenMP threads over row bands
};

std::string_view to_string(Backend backend);
/// Parses "reference" or "cpu"; throws std::invalid_argument naming the accepted values.
Backend parse_backend(std::string_view name);

/// Fixed-point scale of the int16 disparity maps: value = 16 x disparity (as OpenCV's DISP_SHIFT 4).
inline constexpr int kDisparityShift = 4;
inline constexpr int kDisparityScale = 1 << kDisparityShift;

/// Options of a matcher that do not change its result.
struct MatcherOptions {
  /// OpenMP threads of the cpu backend; 0 = the OpenMP default (all cores). Ignored by reference.
  int threads = 0;
  /// Also produce the refined right-view disparity map (the LR check computes a raw one anyway).
  bool compute_right = false;
};

/// Wall time of one stage of the last frame, milliseconds.
struct StageTime {
  std::string stage;
  double ms = 0.0;
};

/// Dense stereo matcher on the (modified) census transform with multi-resolution search.
///
/// The constructor validates the parameters (std::invalid_argument with the message of
/// StereoParams::validate) and allocates every buffer; compute() allocates nothing.
/// Not thread-safe: use one matcher per thread of the caller.
class Matcher {
 public:
  Matcher(int width, int height, const StereoParams& params, Backend backend = Backend::Cpu,
          const MatcherOptions& options = {});
  ~Matcher();
  Matcher(Matcher&&) noexcept;
  Matcher& operator=(Matcher&&) noexcept;
  Matcher(const Matcher&) = delete;
  Matcher& operator=(const Matcher&) = delete;

  /// Matches one rectified pair. Both views must have the configured size; formats may differ
  /// (colour is converted to luma, BT.601). Throws std::invalid_argument on a size mismatch or a
  /// null pointer.
  void compute(const ImageView& left, const ImageView& right);

  /// Left disparity of the last frame, Q4 (16 x pixels); invalid pixels hold invalid_q4().
  /// The view belongs to the matcher and is overwritten by the next compute().
  MapView<const std::int16_t> disparity_q4() const;
  /// Left disparity in pixels, NaN where invalid.
  MapView<const float> disparity() const;
  /// Right-view disparity (Q4; the right pixel x matches left x + d), refined like the left one.
  /// Empty (null data) unless MatcherOptions::compute_right.
  MapView<const std::int16_t> right_disparity_q4() const;

  /// The Q4 value of invalid pixels: (min_disparity - 1) * 16, as OpenCV.
  std::int16_t invalid_q4() const;

  int width() const;
  int height() const;
  const StereoParams& params() const;
  Backend backend() const;
  /// Threads the cpu backend uses (1 for reference).
  int threads() const;
  /// SIMD target chosen at run time ("AVX3", "AVX2", "NEON", ... ; "scalar" for reference).
  std::string simd_target() const;
  /// Per-stage times of the last compute(); the last entry is "frame", the whole call.
  const std::vector<StageTime>& timings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Bytes the matcher allocates for (params, width, height): grows with W x H x (search width at the
/// finest level), not with W x H x D.
std::size_t estimate_memory(const StereoParams& params, int width, int height,
                            const MatcherOptions& options = {});

}  // namespace mctstereo
