// How the cpu stages share their work among threads.
//
// A frame of the cpu backend runs with the matcher's WorkerPool (src/cpu/worker_pool.hpp) in scope
// (PoolScope, opened by the matcher's driver): the calling thread walks the recipe, and each
// stage cuts its rows (or tiles, bands, path blocks) into chunks that the pool's threads take as
// they come. A stage is done when its chunks are done: a thread that the OS has descheduled
// (another process busy on the same cores) holds no share of the work and stalls nobody. With an
// OpenMP `parallel for` per stage, each stage ended in a barrier that waited for every thread, so
// on a loaded CPU every stage waited for a scheduler time slice.
//
// A stage called on its own (a test, the opencl backend's host speckle removal) has no pool in
// scope and opens an OpenMP `parallel for` of its own.
//
// Every chunk writes only its own outputs, so results do not depend on how the work was split:
// the stages stay bit-exact with the reference for any thread count and any schedule.
#pragma once

#include <omp.h>

#include <algorithm>

#include "cpu/worker_pool.hpp"

namespace mctstereo::detail::cpu {

/// The pool of the frame that the calling thread runs, or null (set by PoolScope).
inline thread_local WorkerPool* t_pool = nullptr;

/// Makes `pool` the calling thread's pool while it lives (null: none).
class PoolScope {
 public:
  explicit PoolScope(WorkerPool* pool) : previous_(t_pool) { t_pool = pool; }
  ~PoolScope() { t_pool = previous_; }
  PoolScope(const PoolScope&) = delete;
  PoolScope& operator=(const PoolScope&) = delete;

 private:
  WorkerPool* previous_;
};

/// Set while the calling thread runs one task of a recipe that hands whole tasks to the threads
/// itself (SerialScope): the stages it calls run serially on it.
inline thread_local bool t_serial = false;

/// Makes the stages that the calling thread calls while it lives run serially on it, for a recipe
/// that shares its work among the threads in tasks of several stages each (cpu::sgm_two_sweeps):
/// a stage's own chunks would hand the other threads work while they run tasks of their own.
/// thread_slot() stays the thread's own, so each stage uses the thread's slice of its scratch.
class SerialScope {
 public:
  SerialScope() : pool_(t_pool), serial_(t_serial) {
    t_pool = nullptr;
    t_serial = true;
  }
  ~SerialScope() {
    t_pool = pool_;
    t_serial = serial_;
  }
  SerialScope(const SerialScope&) = delete;
  SerialScope& operator=(const SerialScope&) = delete;

 private:
  WorkerPool* pool_;
  bool serial_;
};

/// Threads that may run a stage's chunks now: the pool's, or what a `parallel for` of the caller's
/// settings would start. Per-thread scratch is indexed by thread_slot() below it.
inline int stage_threads() { return t_serial ? 1 : t_pool ? t_pool->size() : omp_get_max_threads(); }

/// The index of the calling thread among stage_threads(), inside a chunk: a pool's worker knows
/// its slot (t_pool is set only on the thread that runs the frame, whose slot is 0); otherwise
/// the thread's number in the OpenMP team.
inline int thread_slot() {
  const int slot = WorkerPool::slot();
  return slot > 0 || t_pool != nullptr ? slot : omp_get_thread_num();
}

/// Runs body(begin, end) over [0, n) in chunks of `grain` (the last one shorter), in any order and
/// on any thread; returns when every chunk is done. `threads` > 0 caps the threads of a stage
/// called on its own (with a pool, the pool's threads run it).
template <class Body>
void parallel_for(int n, int grain, const Body& body, int threads = 0) {
  if (n <= 0) return;
  grain = std::max(grain, 1);
  const int chunks = (n + grain - 1) / grain;
  if (t_serial) {
    for (int c = 0; c < chunks; ++c) body(c * grain, std::min(n, (c + 1) * grain));
    return;
  }
  if (t_pool != nullptr) {
    struct Context {
      const Body* body;
      int n, grain;
    } const context{&body, n, grain};
    t_pool->run(
        chunks,
        [](const void* p, int c) {
          const auto& ctx = *static_cast<const Context*>(p);
          (*ctx.body)(c * ctx.grain, std::min(ctx.n, (c + 1) * ctx.grain));
        },
        &context);
    return;
  }
  const Body* f = &body;
  const int team = std::max(1, threads > 0 ? std::min(threads, omp_get_max_threads()) : omp_get_max_threads());
#pragma omp parallel for schedule(dynamic, 1) num_threads(team) if (chunks > 1 && team > 1)
  for (int c = 0; c < chunks; ++c) (*f)(c * grain, std::min(n, (c + 1) * grain));
}

/// The grain of a pass over n lines: about kChunksPerThread chunks per thread, so that the others
/// can take over the share of a thread that stalls, and at least `min_grain` lines per chunk, so
/// that a chunk outweighs the cost of handing it out.
inline int lines_grain(int n, int min_grain = 4) {
  constexpr int kChunksPerThread = 4;
  const int target = (n + kChunksPerThread * stage_threads() - 1) / (kChunksPerThread * stage_threads());
  return std::max(target, min_grain);
}

/// parallel_for over the lines [0, n) with lines_grain(n).
template <class Body>
void parallel_lines(int n, const Body& body, int threads = 0) {
  parallel_for(n, lines_grain(n), body, threads);
}

}  // namespace mctstereo::detail::cpu
