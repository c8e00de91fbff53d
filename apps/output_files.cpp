#include "output_files.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

#include "errors.hpp"

namespace mctstereo::app {

namespace fs = std::filesystem;

std::string in_quotes(const fs::path& path) {
  // Appended piece by piece: "'" + string&& trips a false -Wrestrict warning of GCC 12.
  std::string text(1, '\'');
  text += path.string();
  text += '\'';
  return text;
}

namespace {

// True when a and b name the same file: the same inode when both exist (hard and symbolic links
// included), otherwise the same normalised absolute path.
bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  // Absolute first: weakly_canonical leaves a relative path whose first part does not exist
  // relative, so "p.png" and "./p.png" would differ.
  const fs::path ca = fs::weakly_canonical(fs::absolute(a, ec), ec);
  if (ec) return false;
  const fs::path cb = fs::weakly_canonical(fs::absolute(b, ec), ec);
  return !ec && ca == cb;
}

fs::path folder_of(const fs::path& path) {
  const fs::path parent = path.parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

}  // namespace

void check_output_path(const std::string& path, const std::vector<std::string>& inputs, std::string_view what) {
  if (path.empty()) throw UsageError(std::string(what) + ": the file name is empty");
  for (const std::string& input : inputs)
    if (same_file(path, input))
      throw UsageError(std::string(what) + " " + in_quotes(path) + " is the input " + in_quotes(input) +
                       ": refusing to overwrite an input");
  std::error_code ec;
  const fs::path folder = folder_of(path);
  if (!fs::is_directory(folder, ec))
    throw RuntimeError("cannot write " + std::string(what) + " " + in_quotes(path) + ": folder " + in_quotes(folder) +
                       (fs::exists(folder, ec) ? " is not a folder" : " does not exist"));
  if (fs::is_directory(path, ec))
    throw RuntimeError("cannot write " + std::string(what) + " " + in_quotes(path) + ": it is a folder");
}

void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& named_paths) {
  for (std::size_t i = 0; i < named_paths.size(); ++i)
    for (std::size_t j = i + 1; j < named_paths.size(); ++j) {
      const auto& [name_a, a] = named_paths[i];
      const auto& [name_b, b] = named_paths[j];
      if (!a.empty() && !b.empty() && same_file(a, b))
        throw UsageError(name_a + " and " + name_b + " are the same file " + in_quotes(a));
    }
}

PendingOutputs::~PendingOutputs() {
  for (const Entry& e : entries_) {
    std::error_code ec;
    fs::remove(e.temporary, ec);
  }
}

void PendingOutputs::add(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  const fs::path destination(path);
  // Hidden, and unique per process, in the destination's own folder: rename() is only atomic
  // within one file system.
  std::string name(1, '.');
  name += destination.filename().string();
  name += ".tmp-" + std::to_string(::getpid());
  const fs::path temporary = folder_of(destination) / name;
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0)
    throw RuntimeError("cannot write " + in_quotes(destination) + ": " + std::strerror(errno));
  entries_.push_back({temporary, destination});
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      throw RuntimeError("cannot write " + in_quotes(destination) + ": " + std::strerror(err));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0) throw RuntimeError("cannot write " + in_quotes(destination) + ": " + std::strerror(errno));
}

void PendingOutputs::commit() {
  while (!entries_.empty()) {
    const Entry& e = entries_.front();
    std::error_code ec;
    fs::rename(e.temporary, e.destination, ec);
    if (ec) throw RuntimeError("cannot write " + in_quotes(e.destination) + ": " + ec.message());
    entries_.erase(entries_.begin());
  }
}

}  // namespace mctstereo::app
