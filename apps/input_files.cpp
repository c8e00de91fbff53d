#include "input_files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "errors.hpp"
#include "output_files.hpp"

namespace mctstereo::app {

namespace {

// What a file that is not a regular one is, for messages.
const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string failure(const std::string& path, std::string_view role) {
  return "cannot read " + std::string(role) + " " + in_quotes(path) + ": ";
}

void check_mode(mode_t mode, const std::string& path, std::string_view role) {
  if (S_ISREG(mode)) return;
  if (S_ISDIR(mode)) throw RuntimeError(failure(path, role) + "it is a folder, not a file");
  throw RuntimeError(failure(path, role) + "it is " + kind_of(mode) + ", not a regular file");
}

}  // namespace

void check_input_file(const std::string& path, std::string_view role) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) {
    const bool missing = errno == ENOENT || errno == ENOTDIR;
    throw RuntimeError(failure(path, role) + (missing ? "no such file" : std::strerror(errno)));
  }
  check_mode(status.st_mode, path, role);
}

std::string read_input_file(const std::string& path, std::string_view role) {
  check_input_file(path, role);
  // O_NONBLOCK: should the file have become a FIFO since the check, open() still returns.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw RuntimeError(failure(path, role) + std::strerror(errno));
  struct stat status {};
  if (::fstat(fd, &status) != 0 || !S_ISREG(status.st_mode)) {
    const mode_t mode = status.st_mode;
    ::close(fd);
    check_mode(mode, path, role);
    throw RuntimeError(failure(path, role) + "cannot tell what kind of file it is");
  }
  std::string bytes;
  bytes.reserve(static_cast<std::size_t>(status.st_size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int err = errno;
      ::close(fd);
      throw RuntimeError(failure(path, role) + std::strerror(err));
    }
    if (n == 0) break;
    bytes.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return bytes;
}

}  // namespace mctstereo::app
