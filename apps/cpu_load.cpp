#include "cpu_load.hpp"

#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace mctstereo::app {

CpuLoad::CpuLoad(int threads) : threads_(threads) {
  if (threads <= 0) return;
  std::string args[] = {"mctstereo", "bench", "--load-probe", std::to_string(threads)};
  char* argv[] = {args[0].data(), args[1].data(), args[2].data(), args[3].data(), nullptr};
  const int spawned = posix_spawn(&pid_, "/proc/self/exe", nullptr, nullptr, argv, environ);
  if (spawned != 0)
    throw std::runtime_error("--load: cannot start the load process: " + std::string(std::strerror(spawned)));
  // Let its threads start before anything is timed.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
}

CpuLoad::~CpuLoad() {
  if (pid_ <= 0) return;
  kill(pid_, SIGKILL);
  int status = 0;
  while (waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
}

void run_load_probe(int threads) {
  // Ends with the parent, whatever way the parent ends.
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() == 1) std::_Exit(0);
  std::atomic<std::uint64_t> sink{0};
  const auto spin = [&sink](std::uint64_t seed) {
    std::uint64_t x = seed | 1;
    for (;;) {
      for (int i = 0; i < (1 << 20); ++i) x = x * 6364136223846793005ull + 1442695040888963407ull;
      sink.fetch_add(x & 1, std::memory_order_relaxed);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(spin, static_cast<std::uint64_t>(t));
  spin(0);
  std::_Exit(0);  // not reached
}

}  // namespace mctstereo::app
