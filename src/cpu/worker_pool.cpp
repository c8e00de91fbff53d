#include "cpu/worker_pool.hpp"

#include <system_error>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace mctstereo::detail::cpu {
namespace {

thread_local int t_slot = 0;

// The "next chunk" of a job whose fields are being rewritten: larger than any chunk count.
constexpr std::uint32_t kClosed = 0xFFFFFFFFu;

// How long a thread polls before it sleeps. Waiting workers poll for about 50 us: the stages of a
// frame follow each other within microseconds, and a futex wake-up costs more than that gap. The
// caller polls for its last chunks a little longer, then yields its CPU (to a preempted worker
// that holds a chunk, if it shares the core) and finally sleeps.
constexpr int kWorkerPolls = 2000;
constexpr int kCallerPolls = 4000;

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#endif
}

}  // namespace

int WorkerPool::slot() { return t_slot; }

WorkerPool::WorkerPool(int threads) {
  for (int s = 1; s < threads; ++s) {
    try {
      workers_.emplace_back(&WorkerPool::worker_main, this, s);
    } catch (const std::system_error&) {
      break;  // fewer threads, as OpenMP does when it cannot start more
    }
  }
}

WorkerPool::~WorkerPool() {
  stop_.store(true);
  published_.fetch_add(1);
  {
    const std::lock_guard<std::mutex> lock(sleep_mutex_);
    workers_wake_.notify_all();
  }
  for (std::thread& t : workers_) t.join();
}

void WorkerPool::run(int chunks, ChunkFn fn, const void* context) {
  if (chunks <= 0) return;
  if (workers_.empty() || chunks == 1) {
    for (int c = 0; c < chunks; ++c) fn(context, c);
    return;
  }
  const std::uint32_t g = ++generation_;
  // Close the last job's state before its fields are rewritten: a thread that read that state
  // (all chunks claimed) and then this job's chunk count must not claim "chunk N" of it. Its
  // claim compares against the closed state and fails; a thread that sees a field written below
  // (acquire) also sees the closed state (the stores are released in this order).
  state_.store((static_cast<std::uint64_t>(g) << 32) | kClosed, std::memory_order_release);
  fn_.store(fn, std::memory_order_release);
  context_.store(context, std::memory_order_release);
  chunks_.store(chunks, std::memory_order_release);
  done_.store(0, std::memory_order_relaxed);
  state_.store(static_cast<std::uint64_t>(g) << 32, std::memory_order_release);
  published_.store(g);  // seq_cst: see sleep_mutex_
  if (sleepers_.load() > 0) {  // a system call only when a worker sleeps
    const std::lock_guard<std::mutex> lock(sleep_mutex_);
    workers_wake_.notify_all();
  }
  work(g);
  for (int polls = 0; done_.load(std::memory_order_acquire) != chunks; ++polls) {
    if (polls < kCallerPolls) {
      cpu_relax();
    } else if (polls < 2 * kCallerPolls) {
      std::this_thread::yield();
    } else {
      std::unique_lock<std::mutex> lock(sleep_mutex_);
      caller_sleeps_.store(true);
      while (done_.load() != chunks) caller_wake_.wait(lock);
      caller_sleeps_.store(false);
    }
  }
}

void WorkerPool::work(std::uint32_t generation) {
  std::uint64_t s = state_.load(std::memory_order_acquire);
  for (;;) {
    if (static_cast<std::uint32_t>(s >> 32) != generation) return;
    const std::uint32_t chunk = static_cast<std::uint32_t>(s & 0xFFFFFFFFu);
    const int chunks = chunks_.load(std::memory_order_acquire);
    const ChunkFn fn = fn_.load(std::memory_order_acquire);
    const void* context = context_.load(std::memory_order_acquire);
    if (chunk >= static_cast<std::uint32_t>(chunks)) return;  // kClosed included
    if (!state_.compare_exchange_weak(s, s + 1, std::memory_order_acq_rel, std::memory_order_acquire)) continue;
    fn(context, static_cast<int>(chunk));
    if (done_.fetch_add(1) + 1 == chunks && caller_sleeps_.load()) {  // seq_cst: see sleep_mutex_
      const std::lock_guard<std::mutex> lock(sleep_mutex_);
      caller_wake_.notify_one();
    }
    s = state_.load(std::memory_order_acquire);
  }
}

void WorkerPool::worker_main(int slot) {
  t_slot = slot;
  std::uint32_t seen = 0;
  for (;;) {
    std::uint32_t g = published_.load(std::memory_order_acquire);
    for (int polls = 0; g == seen && polls < kWorkerPolls; ++polls) {
      cpu_relax();
      g = published_.load(std::memory_order_acquire);
    }
    if (g == seen) {
      std::unique_lock<std::mutex> lock(sleep_mutex_);
      sleepers_.fetch_add(1);
      while ((g = published_.load()) == seen) workers_wake_.wait(lock);
      sleepers_.fetch_sub(1);
    }
    if (stop_.load(std::memory_order_acquire)) return;
    seen = g;
    work(g);
  }
}

}  // namespace mctstereo::detail::cpu
