// The threads of a cpu matcher: made once with the matcher, they take the chunks of each stage
// as they come, and nobody waits for a thread that has nothing to do.
//
// Why not OpenMP's team: every parallel region ends in a barrier that waits until every thread of
// the team has arrived. On a CPU that another process keeps busy, a thread of ours is often off
// the CPU for a whole scheduler time slice (milliseconds), and each of the ~40 regions of a frame
// then waits for it: two threads ran slower than one. Here a stage is done when its chunks are
// done; a worker that wakes up late finds none left and goes back to sleep, and the caller's
// thread, which takes chunks too, never waits for it. What remains is a chunk that a worker
// started and was preempted in: chunks are small (a few rows), so that costs at most one chunk's
// time slice, and only when it happens.
//
// The protocol: the caller publishes a job (the chunk function and the chunk count) and then a new
// generation in `state_` (generation << 32 | next chunk). Threads claim chunk c by a compare-and-
// swap of (g, c) to (g, c + 1), so a thread still holding generation g can never claim a chunk of
// generation g + 1. Before the caller rewrites the job's fields for g + 1 it sets the state to
// (g + 1, closed): a thread that read g's fields or g + 1's, and then claims against g's state,
// fails, so a successful claim proves that the fields it read belonged to g. The caller returns
// when `done_` reaches the chunk count.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace mctstereo::detail::cpu {

class WorkerPool {
 public:
  using ChunkFn = void (*)(const void* context, int chunk);

  /// threads - 1 worker threads (the caller's thread is the first of `threads`). A thread that
  /// cannot be started (a memory limit) leaves the pool smaller, not broken.
  explicit WorkerPool(int threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Threads that take chunks, the caller's included.
  int size() const { return static_cast<int>(workers_.size()) + 1; }

  /// Runs fn(context, c) for every c in [0, chunks), on the caller's thread and the workers, in
  /// any order; returns when all are done. Not reentrant: one caller at a time.
  void run(int chunks, ChunkFn fn, const void* context);

  /// The slot of the calling thread in the pool that runs it (0 for the caller's thread, 1 ..
  /// size() - 1 for the workers): per-thread scratch is indexed by it.
  static int slot();

 private:
  void work(std::uint32_t generation);
  void worker_main(int slot);

  std::vector<std::thread> workers_;
  std::uint32_t generation_ = 0;  // the caller's count of jobs
  // The job of the current generation. Atomics (relaxed) only so that a worker may read them
  // while the caller writes the next job; it uses what it read only after a claim proved it current.
  std::atomic<ChunkFn> fn_{nullptr};
  std::atomic<const void*> context_{nullptr};
  std::atomic<int> chunks_{0};
  alignas(64) std::atomic<std::uint64_t> state_{0};  // generation << 32 | next chunk
  alignas(64) std::atomic<std::uint32_t> published_{0};  // the generation the workers wait on
  alignas(64) std::atomic<int> done_{0};  // chunks of the current generation finished
  std::atomic<bool> stop_{false};
  // Sleeping, after the polls: the workers until a new generation, the caller until the last
  // chunk is done. A sleeper announces itself (sleepers_, caller_sleeps_) before it checks the
  // condition under the mutex; the other side changes the condition first and notifies under the
  // mutex when it sees an announcement. With sequentially consistent orders on both sides, one
  // of the two always sees the other: no wake-up is lost.
  std::mutex sleep_mutex_;
  std::condition_variable workers_wake_, caller_wake_;
  std::atomic<int> sleepers_{0};
  std::atomic<bool> caller_sleeps_{false};
};

}  // namespace mctstereo::detail::cpu
