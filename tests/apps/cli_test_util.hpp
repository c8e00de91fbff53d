// What the command-line tests share: the program under test, the bundled data, and running a
// shell command with its output captured.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace mctstereo::test {

inline const std::filesystem::path kProgram = MCTSTEREO_CLI;
inline const std::filesystem::path kData = MCTSTEREO_DATA_DIR;

struct Result {
  int status = -1;
  std::string output;  // what the command wrote to its stdout (and stderr where it redirects it there)
};

/// `s` as one word for /bin/sh.
inline std::string shell_quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

/// Runs `command` through /bin/sh; the exit status, or -1 if it did not exit normally.
inline Result run_shell(const std::string& command) {
  Result r;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  while (std::size_t n = std::fread(buf.data(), 1, buf.size(), pipe)) r.output.append(buf.data(), n);
  const int status = ::pclose(pipe);
  r.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace mctstereo::test
