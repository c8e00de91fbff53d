// `mctstereo match LEFT RIGHT -o OUT`: one rectified pair to a disparity file.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "options.hpp"

namespace mctstereo::app {

class MatchCommand {
 public:
  /// Adds the subcommand and its flags to `parent`; must stay where it is until run().
  explicit MatchCommand(CLI::App& parent);
  MatchCommand(const MatchCommand&) = delete;
  MatchCommand& operator=(const MatchCommand&) = delete;

  bool selected() const { return command_->parsed(); }
  /// Matches, writes the outputs and prints the summary line. Throws UsageError / RuntimeError.
  void run() const;

 private:
  CLI::App* command_;
  ParameterFlags parameters_;
  RunFlags run_flags_;
  std::string left_, right_, output_, right_output_, preview_, format_;
  int repeat_ = 1;
};

}  // namespace mctstereo::app
