// `mctstereo bench`: frame times of every preset and of OpenCV's StereoBM and StereoSGBM on the
// same frames, in the same process.
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "options.hpp"

namespace mctstereo::app {

class BenchCommand {
 public:
  /// Adds the subcommand and its flags to `parent`; must stay where it is until run().
  explicit BenchCommand(CLI::App& parent);
  BenchCommand(const BenchCommand&) = delete;
  BenchCommand& operator=(const BenchCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Runs the benchmark, prints the table, writes --json. Throws UsageError / RuntimeError.
  void run() const;

 private:
  CLI::App* command_;
  RunFlags run_flags_;
  std::vector<std::string> sizes_ = {"320x240", "640x480"};
  std::vector<std::string> presets_;
  int num_disparities_ = 64;
  int frames_ = 50;
  int warmup_ = 5;
  double min_time_s_ = 0.5;
  std::string json_, data_, image_left_, image_right_;
};

}  // namespace mctstereo::app
