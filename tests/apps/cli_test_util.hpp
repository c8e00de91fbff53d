// What the command-line tests share: the program under test, the bundled data, running a shell
// command with its output captured, and a fresh folder per test to run it in.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

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

/// Every name in a folder, hidden ones included (a temporary left behind would be hidden).
inline std::set<std::string> folder_listing(const std::filesystem::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) names.insert(entry.path().filename().string());
  return names;
}

/// A test with a folder of its own, named after the suite and the test and removed afterwards, in
/// which commands run: no test can touch data/ or another test's files.
class FolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    folder_ = std::filesystem::temp_directory_path() / ("mctstereo_" + std::string(info->test_suite_name()) + "_" +
                                                        info->name() + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(folder_);
    std::filesystem::create_directories(folder_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(folder_, ec);
  }

  /// Copies the bundled Tsukuba pair into the folder as left.png and right.png.
  void copy_tsukuba_pair() const {
    std::filesystem::copy_file(kData / "tsukuba/imL.png", folder_ / "left.png");
    std::filesystem::copy_file(kData / "tsukuba/imR.png", folder_ / "right.png");
  }

  /// Writes `bytes` to the file `name` of the folder; its path.
  std::string write(const std::string& name, const std::string& bytes) const {
    const std::filesystem::path path = folder_ / name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path.string();
  }

  /// Runs `mctstereo ARGS` in the folder, its stderr with its stdout; `environment` ("VAR=value ")
  /// goes before the program.
  Result run(const std::string& args, const std::string& environment = "") const {
    return run_shell("cd " + shell_quoted(folder_.string()) + " && " + environment + shell_quoted(kProgram.string()) +
                     " " + args + " 2>&1");
  }

  /// Runs `mctstereo ARGS`, which must fail with `status` and one line containing `message`, leaving
  /// the folder exactly as it was: no output, no temporary, every file byte for byte the same.
  void expect_failure(const std::string& args, int status, const std::string& message) const {
    const std::set<std::string> before = folder_listing(folder_);
    std::vector<std::string> contents;
    for (const std::string& name : before)
      if (std::filesystem::is_regular_file(folder_ / name)) contents.push_back(read_text(folder_ / name));
    const Result r = run(args);
    EXPECT_EQ(r.status, status) << "mctstereo " << args << "\n" << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos)
        << "mctstereo " << args << "\nexpected the message to contain: " << message << "\ngot: " << r.output;
    EXPECT_EQ(r.output.rfind("mctstereo: error: ", 0), 0u) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << "one line expected:\n" << r.output;
    EXPECT_EQ(folder_listing(folder_), before) << "mctstereo " << args;
    std::size_t k = 0;
    for (const std::string& name : before)
      if (std::filesystem::is_regular_file(folder_ / name)) EXPECT_EQ(read_text(folder_ / name), contents[k++]) << name;
  }

  std::filesystem::path folder_;
};

}  // namespace mctstereo::test
