// `mctstereo devices`: the OpenCL platforms and devices the opencl backend can run on.
#pragma once

#include <CLI/CLI.hpp>

namespace mctstereo::app {

class DevicesCommand {
 public:
  /// Adds the subcommand to `parent`; must stay where it is until run().
  explicit DevicesCommand(CLI::App& parent);
  DevicesCommand(const DevicesCommand&) = delete;
  DevicesCommand& operator=(const DevicesCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Prints the devices, or why there are none and how to install one. Succeeds either way.
  void run() const;

 private:
  CLI::App* command_;
};

}  // namespace mctstereo::app
