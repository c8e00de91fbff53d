// Busy threads in another process, so that timings can be taken on a loaded CPU, as robots and
// AR devices run the matcher: beside other work, on the same cores.
#pragma once

#include <sys/types.h>

namespace mctstereo::app {

/// Spawns a child process (this program, `bench --load-probe N`) that keeps `threads` threads
/// busy until the object is destroyed; threads == 0 starts nothing. Throws std::runtime_error
/// when the child cannot be started.
class CpuLoad {
 public:
  explicit CpuLoad(int threads);
  ~CpuLoad();
  CpuLoad(const CpuLoad&) = delete;
  CpuLoad& operator=(const CpuLoad&) = delete;
  int threads() const { return threads_; }

 private:
  int threads_ = 0;
  pid_t pid_ = -1;
};

/// The child's work: `threads` threads of integer arithmetic (no memory traffic to speak of)
/// until the process is killed or its parent exits. Does not return.
[[noreturn]] void run_load_probe(int threads);

}  // namespace mctstereo::app
