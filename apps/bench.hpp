// `mctstereo bench`: frame times and per-stage times of the presets against OpenCV's StereoBM and
// StereoSGBM on the same frames, in the same process, over lists of sizes, disparity ranges, thread
// counts and backends (opencl with its kernels' device times); the matcher's peak resident memory
// per size next to estimate_memory().
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace mctstereo::app {

class BenchCommand {
 public:
  /// Adds the subcommand and its flags to `parent`; must stay where it is until run().
  explicit BenchCommand(CLI::App& parent);
  BenchCommand(const BenchCommand&) = delete;
  BenchCommand& operator=(const BenchCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Runs the benchmark, prints the tables, writes --json. Throws UsageError / RuntimeError.
  void run() const;

 private:
  CLI::App* command_;
  std::vector<std::string> sizes_ = {"320x240", "640x480"};
  std::vector<std::string> num_disparities_ = {"64"};
  std::vector<std::string> threads_ = {"0"};
  std::vector<std::string> backends_ = {"cpu"};
  std::string device_;  // OpenCL device of --backend opencl and auto
  std::vector<std::string> presets_;
  int frames_ = 50;
  int warmup_ = 5;
  double min_time_s_ = 0.5;
  std::string json_, data_, image_left_, image_right_;
  std::string fit_ = "stretch";  // --fit
  // Hidden: measure one matcher's memory in this fresh process and print it (see bench.cpp).
  int load_ = 0;
  std::string memory_probe_;
  int load_probe_ = 0;
  bool memory_only_ = false;
  bool fixed_threads_ = false;
};

}  // namespace mctstereo::app
