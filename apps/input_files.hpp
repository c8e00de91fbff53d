// Input files read whole, and the checks made before one is opened: only regular files are read,
// since a FIFO without a writer would block open() for ever and a device need not end.
#pragma once

#include <string>
#include <string_view>

namespace mctstereo::app {

/// RuntimeError "cannot read ROLE 'PATH': ..." unless `path` (links followed) is a regular file:
/// missing ("no such file"), a folder ("it is a folder"), a FIFO, a device or a socket ("it is a
/// FIFO, not a regular file"). Opens nothing, so a FIFO or a device is never touched.
void check_input_file(const std::string& path, std::string_view role);

/// The whole content of the regular file `path` (check_input_file first, then read). RuntimeError
/// as check_input_file, or naming the system's error when it cannot be opened or read.
std::string read_input_file(const std::string& path, std::string_view role);

}  // namespace mctstereo::app
