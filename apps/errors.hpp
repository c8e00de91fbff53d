// The two kinds of failure of the command line, told apart by their exit status.
#pragma once

#include <stdexcept>
#include <string>

namespace mctstereo::app {

/// Exit status of a bad command line: an unknown flag, a parameter out of range, a format that
/// does not fit the file name. The user must change the command.
inline constexpr int kExitUsage = 2;
/// Exit status of a failure while running: a file that cannot be read, decoded or written.
inline constexpr int kExitRuntime = 1;

/// A problem with the arguments (exit status kExitUsage).
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& message) : std::runtime_error(message) {}
};

/// A problem met while running (exit status kExitRuntime).
class RuntimeError : public std::runtime_error {
 public:
  explicit RuntimeError(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace mctstereo::app
