#include "output_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
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

fs::path canonical_name(const fs::path& path) {
  std::error_code ec;
  if (fs::exists(path, ec)) {  // a link is its target, which is what an output written through it replaces
    const fs::path resolved = fs::canonical(path, ec);
    if (!ec) return resolved;
  }
  const fs::path absolute = fs::absolute(path, ec).lexically_normal();
  if (ec) return path.lexically_normal();
  // The folder is resolved on its own: weakly_canonical keeps a ".." after a part that does not
  // exist, and "s/../x.pfm" names x.pfm only if s exists, in which case it is resolved too.
  const fs::path folder = fs::weakly_canonical(absolute.parent_path(), ec);
  return ec ? absolute : (folder / absolute.filename()).lexically_normal();
}

namespace {

// True when a and b name the same file: the same inode when both exist (hard and symbolic links
// included), otherwise the same canonical name.
bool same_file(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  return canonical_name(a) == canonical_name(b);
}

fs::path folder_of(const fs::path& path) {
  const fs::path parent = path.parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

// How an output reaches its file.
struct Target {
  fs::path file;           // where the bytes go: the path, or the regular file a link points to
  bool in_place = false;   // a device or a FIFO: written where it is, never replaced
  std::string problem;     // why it cannot be written; "" when it can
};

// /dev/stdout, /dev/stderr, /dev/fd/N and /proc/self/fd/N name a file this process has open: it is
// written through the descriptor, at its offset, even when it is a regular file (`-o /dev/stdout >
// d.pfm`), since replacing that file would leave the open one, and what is written to it later,
// unlinked. The descriptor `path` names (`/dev/stdout` 1, `/dev/fd/5` 5), or -1 when it names none.
int open_descriptor(const std::string& path) {
  if (path == "/dev/stdout") return 1;
  if (path == "/dev/stderr") return 2;
  for (const std::string prefix : {"/dev/fd/", "/proc/self/fd/"}) {
    if (path.rfind(prefix, 0) != 0) continue;
    const std::string number = path.substr(prefix.size());
    const bool digits = !number.empty() && number.find_first_not_of("0123456789") == std::string::npos;
    return digits && number.size() <= 9 ? std::stoi(number) : -1;
  }
  return -1;
}

Target target_of(const std::string& path) {
  if (open_descriptor(path) >= 0) return {path, true, ""};
  struct stat link {};
  if (::lstat(path.c_str(), &link) != 0) return {path, false, ""};  // a new file
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) return {path, false, "it is a symbolic link to a missing file"};
  if (S_ISREG(status.st_mode)) {
    if (!S_ISLNK(link.st_mode)) return {path, false, ""};
    std::error_code ec;
    const fs::path file = fs::canonical(path, ec);
    return {file, false, ec ? "cannot resolve the symbolic link: " + ec.message() : ""};
  }
  if (S_ISCHR(status.st_mode) || S_ISFIFO(status.st_mode)) return {path, true, ""};
  if (S_ISDIR(status.st_mode)) return {path, false, "it is a folder"};
  if (S_ISBLK(status.st_mode)) return {path, false, "it is a block device"};
  return {path, false, "it is a socket or another special file"};
}

bool is_character_device(const std::string& path) {
  struct stat status {};
  return ::stat(path.c_str(), &status) == 0 && S_ISCHR(status.st_mode);
}

// Writes every byte to `fd`; the errno of the failure, 0 on success.
int write_all(int fd, const std::vector<std::uint8_t>& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n < 0 ? errno : EIO;
    done += static_cast<std::size_t>(n);
  }
  return 0;
}

[[noreturn]] void fail_writing(const std::string& path, int error) {
  throw RuntimeError("cannot write " + in_quotes(path) + ": " + std::strerror(error));
}

// Writes a device or a FIFO where it is. A FIFO is opened without waiting, so one that no process
// reads fails at once (ENXIO) instead of blocking; the writes then block as usual.
void write_in_place(const std::string& path, const fs::path& file, const std::vector<std::uint8_t>& bytes) {
  if (const int descriptor = open_descriptor(path); descriptor >= 0) {
    // Through the descriptor itself: opening /dev/stdout anew would write a regular file from its
    // start, over what the program wrote before (and under what it writes after).
    std::cout.flush();
    std::cerr.flush();
    if (const int error = write_all(descriptor, bytes); error != 0) fail_writing(path, error);
    return;
  }
  const int fd = ::open(file.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENXIO) throw RuntimeError("cannot write " + in_quotes(path) + ": it is a FIFO that no process reads");
    fail_writing(path, errno);
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  const int error = write_all(fd, bytes);
  const int closed = ::close(fd) == 0 ? 0 : errno;
  if (error != 0 || closed != 0) fail_writing(path, error != 0 ? error : closed);
}

}  // namespace

void check_output_path(const std::string& path, const std::vector<std::string>& inputs, std::string_view what) {
  if (path.empty()) throw UsageError(std::string(what) + ": the file name is empty");
  for (const std::string& input : inputs)
    if (same_file(path, input))
      throw UsageError(std::string(what) + " " + in_quotes(path) + " is the input " + in_quotes(input) +
                       ": refusing to overwrite an input");
  const Target target = target_of(path);
  if (!target.problem.empty())
    throw RuntimeError("cannot write " + std::string(what) + " " + in_quotes(path) + ": " + target.problem);
  std::error_code ec;
  const fs::path folder = folder_of(target.file);
  if (!fs::is_directory(folder, ec))
    throw RuntimeError("cannot write " + std::string(what) + " " + in_quotes(path) + ": folder " + in_quotes(folder) +
                       (fs::exists(folder, ec) ? " is not a folder" : " does not exist"));
}

fs::path regular_output_file(const std::string& path, std::string_view what) {
  const Target target = target_of(path);
  if (target.in_place)
    throw RuntimeError("cannot write " + std::string(what) + " " + in_quotes(path) +
                       ": it is a device or a FIFO, and a " + std::string(what) + " must be a regular file");
  if (!target.problem.empty())
    throw RuntimeError("cannot write " + std::string(what) + " " + in_quotes(path) + ": " + target.problem);
  return target.file;
}

void check_distinct_outputs(const std::vector<std::pair<std::string, std::string>>& named_paths) {
  for (std::size_t i = 0; i < named_paths.size(); ++i)
    for (std::size_t j = i + 1; j < named_paths.size(); ++j) {
      const auto& [name_a, a] = named_paths[i];
      const auto& [name_b, b] = named_paths[j];
      if (a.empty() || b.empty() || is_character_device(a)) continue;  // /dev/null may take several
      if (same_file(a, b)) throw UsageError(name_a + " and " + name_b + " are the same file " + in_quotes(a));
    }
}

PendingOutputs::~PendingOutputs() {
  for (const Entry& e : entries_) {
    std::error_code ec;
    if (!e.temporary.empty()) fs::remove(e.temporary, ec);
  }
}

void PendingOutputs::add(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  const Target target = target_of(path);
  if (!target.problem.empty()) throw RuntimeError("cannot write " + in_quotes(path) + ": " + target.problem);
  if (target.in_place) {
    entries_.push_back({path, {}, target.file, bytes});
    return;
  }
  for (const Entry& e : entries_)
    if (!e.temporary.empty() && same_file(e.destination, target.file))
      throw RuntimeError("cannot write " + in_quotes(path) + ": it is " + in_quotes(e.path) + ", written already");
  // Hidden, and unique per process and output, in the destination's own folder: rename() is only
  // atomic within one file system.
  std::string name(1, '.');
  name += target.file.filename().string();
  name += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(entries_.size());
  const fs::path temporary = folder_of(target.file) / name;
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) fail_writing(path, errno);
  entries_.push_back({path, temporary, target.file, {}});
  const int error = write_all(fd, bytes);
  const int closed = ::close(fd) == 0 ? 0 : errno;  // NFS and some others report a full disk here
  if (error != 0 || closed != 0) fail_writing(path, error != 0 ? error : closed);
}

void PendingOutputs::commit() {
  // In place first: a device or FIFO is the likeliest to fail, and then no file has been replaced.
  for (const Entry& e : entries_)
    if (e.temporary.empty()) write_in_place(e.path, e.destination, e.in_place_bytes);
  while (!entries_.empty()) {
    const Entry& e = entries_.front();
    if (!e.temporary.empty()) {
      std::error_code ec;
      fs::rename(e.temporary, e.destination, ec);
      if (ec) throw RuntimeError("cannot write " + in_quotes(e.path) + ": " + ec.message());
    }
    entries_.erase(entries_.begin());
  }
}

}  // namespace mctstereo::app
