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

/// The absolute, normalised name of `path` with its links resolved (those of its folder when it
/// does not exist): the same for "x.pfm", "./x.pfm", "$PWD/x.pfm" and "s/../x.pfm" whether or not
/// x.pfm exists yet, and for a symbolic link and the file it points to.
std::filesystem::path canonical_name(const std::filesystem::path& path);

/// Checks, before anything is computed, that `path` may receive the output `what` (for messages,
/// e.g. "disparity output"): it is not one of `inputs` (UsageError), its folder exists, and `path`
/// is not a folder, a block device, a socket or a link to nothing (RuntimeError).
void check_output_path(const std::string& path, const std::vector<std::string>& inputs, std::string_view what);

/// The regular file an output that cannot be written in place goes to (a video, whose header is
/// rewritten at the end): `path`, or the file a symbolic link points to. RuntimeError naming `what`
/// when `path` is a device, a FIFO or another special file.
std::filesystem::path regular_output_file(const std::string& path, std::string_view what);

/// Throws UsageError when two of `paths` name the same file, however spelt and whether or not it
/// exists yet (empty entries and character devices such as /dev/null are ignored).
void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& named_paths);

/// Files that appear whole or not at all, written together by commit().
/// - A regular file (or a name that does not exist yet) is written to a temporary next to it and
///   renamed into place: a rename within one folder is atomic, so a reader never sees a half-written
///   file. A symbolic link to a regular file is written through: the temporary goes next to the
///   file it points to and replaces that file, so the link stays a link.
/// - A character device (/dev/null) or a FIFO is written in place, since renaming would replace
///   it; a FIFO that no process reads is refused rather than waited for. So is a file the process
///   has open (/dev/stdout, /dev/fd/N), whatever it is.
/// Every write, flush and close is checked: a full disk (or /dev/full) is a RuntimeError naming
/// the file. Temporaries that were not committed are removed by the destructor.
class PendingOutputs {
 public:
  PendingOutputs() = default;
  PendingOutputs(const PendingOutputs&) = delete;
  PendingOutputs& operator=(const PendingOutputs&) = delete;
  ~PendingOutputs();

  /// Writes `bytes` to a new temporary file next to `path`, or keeps them for commit() when `path`
  /// is written in place. RuntimeError on failure, or when `path` was added already.
  void add(const std::string& path, const std::vector<std::uint8_t>& bytes);
  /// Writes the outputs that are written in place, then renames every temporary onto its
  /// destination, in the order they were added.
  void commit();

 private:
  struct Entry {
    std::string path;                         // as given, for messages
    std::filesystem::path temporary, destination;
    std::vector<std::uint8_t> in_place_bytes;  // written at commit(); used when temporary is empty
  };
  std::vector<Entry> entries_;
};

}  // namespace mctstereo::app
