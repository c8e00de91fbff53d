// Output files that appear whole or not at all, and the checks made before any work is done.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace mctstereo::app {

/// The path in single quotes, for messages.
std::string in_quotes(const std::filesystem::path& path);

/// Checks, before anything is computed, that `path` may receive the output `what` (for messages,
/// e.g. "disparity output"): it is not one of `inputs` (UsageError), its folder exists and `path`
/// is not a folder (RuntimeError).
void check_output_path(const std::string& path, const std::vector<std::string>& inputs, std::string_view what);

/// Throws UsageError when two of `paths` name the same file (empty entries are ignored).
void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& named_paths);

/// Files written to temporaries next to their destinations and renamed into place together by
/// commit(). A rename within one folder is atomic, so a reader never sees a half-written file;
/// temporaries that were not committed (an error, an exception) are removed by the destructor.
class PendingOutputs {
 public:
  PendingOutputs() = default;
  PendingOutputs(const PendingOutputs&) = delete;
  PendingOutputs& operator=(const PendingOutputs&) = delete;
  ~PendingOutputs();

  /// Writes `bytes` to a new temporary file in the folder of `path` (RuntimeError on failure).
  void add(const std::string& path, const std::vector<std::uint8_t>& bytes);
  /// Renames every temporary onto its destination, in the order they were added.
  void commit();

 private:
  struct Entry {
    std::filesystem::path temporary, destination;
  };
  std::vector<Entry> entries_;
};

}  // namespace mctstereo::app
