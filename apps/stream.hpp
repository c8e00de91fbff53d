// `mctstereo stream`: live stereo from videos, image sequences or cameras, frame by frame.
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <string>

#include "calibration.hpp"
#include "frame_source.hpp"
#include "options.hpp"

namespace mctstereo::app {

class StreamCommand {
 public:
  /// Adds the subcommand and its flags to `parent`; must stay where it is until run().
  explicit StreamCommand(CLI::App& parent);
  StreamCommand(const StreamCommand&) = delete;
  StreamCommand& operator=(const StreamCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Reads, matches and writes every frame, then prints the summary line. Throws UsageError /
  /// RuntimeError; a stop by SIGINT or SIGTERM is a normal end.
  void run() const;

 private:
  CLI::App* command_;
  ParameterFlags parameters_;
  RunFlags run_flags_;
  CalibrationFlags calibration_flags_;
  StereoInputSpec input_;
  int start_ = 0, max_frames_ = 0;
  std::string disparity_, format_, depth_, preview_video_;
  double max_depth_ = 0.0;  // 0 = no cut
  bool show_ = false, quiet_ = false;
  bool temporal_ = false;
  std::optional<int> temporal_radius_, temporal_threshold_;
};

}  // namespace mctstereo::app
