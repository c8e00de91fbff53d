// What the reports of `eval` and `bench` say about the machine and the build
// they ran on.
#pragma once

#include <string>

namespace mctstereo::app {

/// The CPU's model name from /proc/cpuinfo, or "unknown".
std::string cpu_model();
/// The clock of the first CPU in MHz from /proc/cpuinfo ("cpu MHz"; on a virtual machine the
/// host's nominal clock), or 0 where there is none.
double cpu_mhz();
/// A "kB" line of /proc/self/status ("VmRSS", "VmHWM"), KiB; -1 where there is
/// none.
long status_kib(const std::string &key);
/// The compiler and its version.
std::string compiler_version();
/// CMake's build type when the build passes it on; otherwise what the compiler
/// flags tell.
std::string build_type();
/// Now, as 2026-01-31T12:00:00Z.
std::string utc_date();

}  // namespace mctstereo::app
