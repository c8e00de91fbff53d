// The cpu backend's worker pool and the chunked loops over it: every chunk runs exactly once per
// job, on a slot no other thread holds at the same time, across many jobs in a row; a stalled
// chunk holds up only its own job's end; a pool whose threads cannot all start is smaller, not
// broken.
#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "cpu/load_policy.hpp"
#include "cpu/parallel.hpp"
#include "cpu/worker_pool.hpp"

namespace mctstereo::detail::cpu {
namespace {

// Each chunk counts itself and marks its slot busy while it runs: two threads on one slot at once
// (shared per-thread scratch) would find the mark set.
struct Tally {
  std::vector<std::atomic<int>> runs;
  std::vector<std::atomic<int>> busy;
  std::atomic<int> slot_clashes{0}, bad_slots{0};
  Tally(int chunks, int slots) : runs(chunks), busy(slots) {}
};

void count_chunk(const void* context, int chunk) {
  auto& t = *static_cast<Tally*>(const_cast<void*>(context));
  const int slot = WorkerPool::slot();
  if (slot < 0 || slot >= static_cast<int>(t.busy.size())) {
    ++t.bad_slots;
    return;
  }
  if (t.busy[slot].exchange(1) != 0) ++t.slot_clashes;
  // A little work of uneven length, which the compiler may not remove.
  volatile int spin = 0;
  while (spin < (chunk % 7) * 200) spin = spin + 1;
  ++t.runs[chunk];
  t.busy[slot].store(0);
}

// Jobs follow each other at once with chunk counts that alternate between small and large: a
// thread that read the end of one job and then the next job's larger count must not claim a
// chunk "past the end" of the first (it would run a chunk twice, or after the caller returned).
TEST(WorkerPool, EveryChunkRunsOnceOnAFreeSlotInEveryJob) {
  for (const int threads : {1, 2, 3}) {
    WorkerPool pool(threads);
    ASSERT_EQ(pool.size(), threads);
    for (int job = 0; job < 20000; ++job) {
      const int chunks = job % 2 ? job % 37 : 2 + job % 5;  // 0 and 1 included: none, and one inline
      Tally tally(chunks, pool.size());
      pool.run(chunks, count_chunk, &tally);
      for (int c = 0; c < chunks; ++c) ASSERT_EQ(tally.runs[c].load(), 1) << "job " << job << " chunk " << c;
      ASSERT_EQ(tally.slot_clashes.load(), 0) << "job " << job;
      ASSERT_EQ(tally.bad_slots.load(), 0) << "job " << job;
    }
  }
}

// A chunk that waits for another chunk of the same job can finish only if some other thread takes
// that chunk: the pool hands chunks to any free thread, the caller's included.
TEST(WorkerPool, ChunksOfOneJobRunConcurrently) {
  WorkerPool pool(2);
  std::atomic<int> arrived{0};
  const auto meet = [](const void* context, int) {
    auto& a = *static_cast<std::atomic<int>*>(const_cast<void*>(context));
    ++a;
    while (a.load() < 2) std::this_thread::yield();
  };
  pool.run(2, meet, &arrived);
  EXPECT_EQ(arrived.load(), 2);
}

TEST(ParallelFor, CoversTheRangeOnceWithAndWithoutAPool) {
  for (const bool with_pool : {false, true}) {
    WorkerPool pool(2);
    const PoolScope scope(with_pool ? &pool : nullptr);
    for (const int n : {0, 1, 5, 64, 481}) {
      for (const int grain : {1, 3, 64, 1000}) {
        std::vector<std::atomic<int>> seen(n);
        parallel_for(n, grain, [&](int begin, int end) {
          EXPECT_LE(end - begin, grain);
          for (int i = begin; i < end; ++i) ++seen[i];
        });
        for (int i = 0; i < n; ++i) ASSERT_EQ(seen[i].load(), 1) << "n " << n << " grain " << grain << " i " << i;
      }
    }
    EXPECT_EQ(stage_threads(), with_pool ? 2 : omp_get_max_threads());
  }
  EXPECT_EQ(t_pool, nullptr) << "the scope gives the previous pool back";
}

TEST(LoadPolicy, RunsTheFasterWayAndTriesTheOtherLessOftenWhileItLoses) {
  LoadPolicy p;
  // Frame times of a way: the threads 10 ms, alone `alone_ms`. Returns the frames alone of `n`.
  double alone_ms = 15.0;
  const auto frames = [&](int n) {
    int alone = 0;
    for (int i = 0; i < n; ++i) {
      const bool threads = p.use_threads();
      alone += !threads;
      p.record(threads, threads ? 10.0 : alone_ms);
    }
    return alone;
  };
  // Idle: the threads, with trials alone of 3 frames after 3, 32, 64, 128, 256, 256 ... frames.
  EXPECT_TRUE(p.use_threads());
  EXPECT_EQ(frames(3), 0);
  EXPECT_EQ(frames(3), 3);  // the first trial
  EXPECT_EQ(p.frames_to_trial(), 32);
  EXPECT_EQ(frames(32 + 3 + 64 + 3 + 128 + 3), 9);
  EXPECT_EQ(p.frames_to_trial(), 256);
  EXPECT_EQ(frames(256 + 3), 3);
  EXPECT_EQ(p.frames_to_trial(), LoadPolicy::kLongestGap);
  // Loaded, where the threads keep their time: alone becomes faster. The next trial finds it so,
  // and frames run alone from then on, with trials of the threads after 16, 32, ... frames.
  alone_ms = 6.0;
  EXPECT_EQ(frames(256 + 3), 3);
  EXPECT_FALSE(p.use_threads());
  EXPECT_EQ(p.frames_to_trial(), LoadPolicy::kFirstGap);
  EXPECT_EQ(frames(16), 16);
  EXPECT_EQ(frames(3), 0);  // the trial of the threads, still slower
  EXPECT_EQ(p.frames_to_trial(), 32);
  // The load goes: the frames alone take longer than the threads' last trial, so the threads are
  // tried 16 frames after it, not 32, and win back.
  alone_ms = 15.0;
  EXPECT_EQ(frames(16), 16);
  EXPECT_EQ(p.frames_to_trial(), 0);
  EXPECT_EQ(frames(3), 0);
  EXPECT_TRUE(p.use_threads());
  EXPECT_EQ(p.frames_to_trial(), LoadPolicy::kFirstGap);
}

// A load that slows the way that runs calls a trial of the other way 16 frames after the last
// trial, not at the end of a gap of up to 256; and a trial is judged by the median of its frames,
// so that one frame the OS preempted does not decide.
TEST(LoadPolicy, TriesTheOtherWayWhenTheLoadStartsAndIgnoresAPreemptedFrame) {
  LoadPolicy p;
  const auto run = [&](int n, double threads_ms, double alone_ms) {
    int alone = 0;
    for (int i = 0; i < n; ++i) {
      const bool threads = p.use_threads();
      alone += !threads;
      p.record(threads, threads ? threads_ms : alone_ms);
    }
    return alone;
  };
  // Idle until the gap is the longest: threads 10 ms, alone 15.
  EXPECT_EQ(run(3 + 3 + 32 + 3 + 64 + 3 + 128 + 3, 10.0, 15.0), 12);
  EXPECT_EQ(p.frames_to_trial(), LoadPolicy::kLongestGap);
  // The load starts: the threads take 20 ms, alone 12. Their median passes alone's 15 within the
  // 16 frames after the last trial, and the trial comes then.
  EXPECT_EQ(run(16, 20.0, 12.0), 0);
  EXPECT_EQ(p.frames_to_trial(), 0);
  EXPECT_EQ(run(3, 20.0, 12.0), 3);
  EXPECT_FALSE(p.use_threads());
  // A trial of the threads whose third frame was preempted: 8, 8 and 80 ms against alone's 12.
  EXPECT_EQ(run(16, 8.0, 12.0), 16);
  for (const double ms : {8.0, 8.0, 80.0}) {
    ASSERT_TRUE(p.use_threads());
    p.record(true, ms);
  }
  EXPECT_TRUE(p.use_threads()) << "the median of the trial, 8 ms, wins";
  // Alone, one slow frame among the recent ones does not call a trial either.
  LoadPolicy q;
  for (int i = 0; i < 3; ++i) q.record(true, 10.0);
  for (int i = 0; i < 3; ++i) q.record(false, 15.0);  // the first trial: the threads stay
  ASSERT_TRUE(q.use_threads());
  for (int i = 0; i < 20; ++i) q.record(true, i == 17 ? 100.0 : 10.0);
  EXPECT_EQ(q.frames_to_trial(), 32 - 20);
}

// A matcher made on a loaded CPU: its first 3 frames on the threads, the next 3 alone, and alone
// from then on, with the threads tried again 16 frames later.
TEST(LoadPolicy, AMatcherMadeUnderLoadRunsAloneFromItsSeventhFrame) {
  LoadPolicy p;
  std::vector<bool> on_threads;
  for (int i = 0; i < 6 + 16; ++i) {
    on_threads.push_back(p.use_threads());
    p.record(on_threads.back(), on_threads.back() ? 20.0 : 12.0);
  }
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(on_threads[i]) << "frame " << i;
  for (int i = 3; i < 6 + 16; ++i) EXPECT_FALSE(on_threads[i]) << "frame " << i;
  EXPECT_EQ(p.frames_to_trial(), 0);
  EXPECT_TRUE(p.use_threads()) << "the trial of the threads";
}

}  // namespace
}  // namespace mctstereo::detail::cpu
