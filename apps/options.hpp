// Flags shared by the subcommands: the stereo parameters (a preset, then one flag per field of
// StereoParams) and the backend, OpenCL device and thread count.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "json.hpp"
#include "mctstereo/mctstereo.hpp"

namespace mctstereo::app {

/// --preset and one flag per StereoParams field. The preset is applied first, then every flag the
/// user gave, so `--preset quality --median 3` is the quality preset with a 3 x 3 median.
class ParameterFlags {
 public:
  /// Adds the flags to `app`. The object receives the parsed values, so it must outlive parsing
  /// and stay where it is (not copyable, not movable).
  explicit ParameterFlags(CLI::App& app);
  ParameterFlags(const ParameterFlags&) = delete;
  ParameterFlags& operator=(const ParameterFlags&) = delete;

  /// The preset with the flags that were given on top. UsageError for an unknown preset.
  StereoParams resolve() const;
  const std::string& preset_name() const { return preset_name_; }
  /// Whether a flag (its long name, e.g. "--num-disparities") was on the command line.
  bool given(std::string_view flag) const;

 private:
  template <typename T>
  void add(CLI::App& app, const std::string& names, T& storage, const std::string& help,
           std::function<void(StereoParams&)> apply);

  struct Override {
    std::string flag;  // the long name, e.g. "--subpixel"
    CLI::Option* option;
    std::function<void(StereoParams&)> apply;
  };
  std::string preset_name_ = "balanced";
  StereoParams values_;  // receives the numeric and boolean flags
  std::string census_, mct_kernel_, fill_, aggregation_, weighted_median_;
  std::vector<Override> overrides_;
};

/// --backend, --device, --threads, --fixed-threads and --sgm-volume-limit.
struct RunFlags {
  std::string backend = "cpu";
  std::string device;  // "" = the first GPU, else the first device
  int threads = 0;
  double sgm_volume_limit_mib = static_cast<double>(MatcherOptions{}.sgm_volume_limit >> 20);
  bool fixed_threads = false;  // --fixed-threads: MatcherOptions::adapt_threads = false

  void add_to(CLI::App& app);
  /// UsageError for an unknown backend, or --device with a backend that has none.
  Backend parsed_backend() const;
  /// --threads, --fixed-threads, --device and --sgm-volume-limit as matcher options.
  MatcherOptions matcher_options(bool compute_right = false, bool compute_confidence = false) const;
  /// The matcher of these flags. Prints the notice of --backend auto ("mctstereo: note: ...") on
  /// stderr when it fell back to the cpu backend. RuntimeError naming the flag when the OpenCL
  /// device cannot be had (none installed, --device names none, a kernel fails to build, too
  /// little device memory); std::invalid_argument (usage) for bad parameters.
  /// With the cpu backend, as many threads as can be started (a memory limit may allow fewer than
  /// --threads: a note says so), and RuntimeError naming the size and the memory needed when there
  /// is not enough memory for the matcher.
  Matcher make_matcher(int width, int height, const StereoParams& params, bool compute_right = false,
                       bool compute_confidence = false) const;

 private:
  Matcher construct_matcher(int width, int height, const StereoParams& params, bool compute_right,
                            bool compute_confidence, int thread_count) const;
};

/// The help text of --backend and --device.
extern const char* const kBackendHelp;
extern const char* const kDeviceHelp;

/// Throws UsageError("invalid parameters: ...") when `params` are invalid whatever the image size.
void check_parameters(const StereoParams& params);
/// Throws UsageError("invalid parameters: ...") when `params` do not suit a width x height image,
/// with every problem StereoParams::validate found on one line and the flag to change named.
void check_parameters(const StereoParams& params, int width, int height);

/// Puts before the checks of every numeric flag of `app` and of its subcommands one that refuses an
/// empty value (which CLI11 would read as 0) and, for floating-point flags, anything but a finite
/// number: NaN, infinities, numbers beyond a double or closer to 0 than a normal one.
void refuse_empty_and_non_finite_numbers(CLI::App& app);

/// Every field of `params`, named as in StereoParams.
Json parameters_json(const StereoParams& params);

}  // namespace mctstereo::app
