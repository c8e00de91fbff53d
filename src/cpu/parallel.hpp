// How the cpu stages share their work among threads.
//
// A frame of the cpu backend runs inside one OpenMP parallel region (FrameRegion, opened by the
// matcher's driver): the calling thread walks the recipe, and each stage hands its rows (or tiles,
// bands, path blocks) out as tasks that every thread of the team takes as it comes. The calling
// thread waits at the end of a stage only for the chunks that have started: a thread that the OS
// has descheduled (another process busy on the same cores) holds no share of the work, and the
// others do all of it. With a `parallel for` per stage, each stage ended in a barrier that waited
// for every thread, so on a loaded CPU every stage of the frame waited for a scheduler time slice.
// The team meets at a barrier once per frame, where the region ends.
//
// A stage called on its own (a test, the opencl backend's host speckle removal) has no region
// around it and opens a `parallel for` of its own, as before.
//
// Every chunk writes only its own outputs, so results do not depend on how the work was split:
// the stages stay bit-exact with the reference for any thread count and any schedule.
#pragma once

#include <omp.h>

#include <algorithm>
#include <exception>

namespace mctstereo::detail::cpu {

/// True on the thread that runs a frame inside FrameRegion (set and cleared by FrameRegion).
inline thread_local bool t_in_frame_region = false;

/// Threads that may run a stage's chunks now: the frame's team, or what a `parallel for` of the
/// caller's settings would start. Per-thread scratch is indexed by omp_get_thread_num() below it.
inline int stage_threads() { return t_in_frame_region ? omp_get_num_threads() : omp_get_max_threads(); }

/// Runs body(begin, end) over [0, n) in chunks of `grain` (the last one shorter), in any order and
/// on any thread of the team; returns when every chunk is done. `threads` > 0 caps the threads of
/// a stage called on its own (inside a frame the team is the matcher's).
template <class Body>
void parallel_for(int n, int grain, const Body& body, int threads = 0) {
  if (n <= 0) return;
  grain = std::max(grain, 1);
  const int chunks = (n + grain - 1) / grain;
  const Body* f = &body;  // the tasks copy the pointer, not the callable
  if (t_in_frame_region) {
    if (chunks == 1 || omp_get_num_threads() == 1) {
      (*f)(0, n);
      return;
    }
    // The implicit taskgroup of taskloop waits for the chunks, executing them meanwhile.
#pragma omp taskloop grainsize(1) firstprivate(f, n, grain)
    for (int c = 0; c < chunks; ++c) (*f)(c * grain, std::min(n, (c + 1) * grain));
    return;
  }
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

/// The parallel region around one frame: the constructing thread runs `recipe()` while the
/// other threads of the team run the chunks its stages hand out. `threads` <= 1 runs the recipe
/// without a region. An exception from the recipe is rethrown after the region has ended.
template <class Recipe>
void run_in_frame_region(int threads, const Recipe& recipe) {
  if (threads <= 1) {
    recipe();
    return;
  }
  std::exception_ptr error;
  const Recipe* r = &recipe;
#pragma omp parallel num_threads(threads)
  {
#pragma omp master
    {
      t_in_frame_region = true;
      try {
        (*r)();
      } catch (...) {
        error = std::current_exception();
      }
      t_in_frame_region = false;
    }
    // The others wait at the region's end barrier, where they run the tasks the recipe creates.
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace mctstereo::detail::cpu
