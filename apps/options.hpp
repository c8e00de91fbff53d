// Flags shared by the subcommands: the stereo parameters (a preset, then one flag per field of
// StereoParams) and the backend and thread count.
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
  std::string census_, mct_kernel_, fill_;
  std::vector<Override> overrides_;
};

/// --backend and --threads.
struct RunFlags {
  std::string backend = "cpu";
  int threads = 0;

  void add_to(CLI::App& app);
  /// UsageError for an unknown backend.
  Backend parsed_backend() const;
};

/// Throws UsageError("invalid parameters: ...") when `params` are invalid whatever the image size.
void check_parameters(const StereoParams& params);
/// Throws UsageError("invalid parameters: ...") when `params` do not suit a width x height image,
/// with every problem StereoParams::validate found on one line and the flag to change named.
void check_parameters(const StereoParams& params, int width, int height);

/// Every field of `params`, named as in StereoParams.
Json parameters_json(const StereoParams& params);

}  // namespace mctstereo::app
