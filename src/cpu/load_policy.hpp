// Whether a frame of the cpu backend runs on the matcher's threads or on the caller's thread alone
// (MatcherOptions::adapt_threads).
//
// The pool hands out small chunks and never waits for a thread that has not started one, but a
// worker that the OS takes off the CPU in the middle of a chunk holds up the end of its stage for
// the rest of a scheduler time slice (milliseconds), and a waiting thread spends its own share of
// the CPU polling. On a CPU that other processes keep busy that happens at stage after stage, and
// 2 threads ran slower than 1 (bench --load 2). So the matcher keeps the recent frame times of each
// way, runs its frames the faster way, and tries the other way for a few frames now and then: first
// after the threads' first 3 frames (a matcher made on a loaded CPU then runs alone from its 7th
// frame on, not its 20th; on an idle one the early trial costs 3 slower frames once), then 16
// frames after a trial that changed the way, and twice as many after each trial that confirmed
// it (at most 256), so that on an idle machine the trials cost little; and as soon as the way it
// runs has become slower than the other was when last tried (a load that starts), at most every
// 16 frames. The maps do not depend on it: every stage is bit-exact for any thread count.
//
// Each way's time is the median of its last frames, and a trial's the median of its 3 frames: on a
// loaded CPU a frame that the OS preempts takes several times the others, and a mean of a trial's
// frames followed it (measured: 2 threads ran 113 of 119 frames at 5.3 ms where 1 took 3.0).
#pragma once

#include <algorithm>
#include <array>

#include "mctstereo/matcher.hpp"

namespace mctstereo::detail::cpu {

/// The last few frame times of one way, and their median.
class RecentTimes {
 public:
  static constexpr int kCapacity = 8;

  void clear() { count_ = next_ = 0; }
  void push(double ms) {
    times_[next_] = ms;
    next_ = (next_ + 1) % kCapacity;
    count_ = std::min(count_ + 1, kCapacity);
  }
  int count() const { return count_; }
  /// The median of the stored times (the upper one of an even count); -1 without any.
  double median() const {
    if (count_ == 0) return -1;
    std::array<double, kCapacity> sorted{};
    for (int i = 0; i < count_; ++i) {  // insertion sort of at most 8
      int j = i;
      for (; j > 0 && sorted[j - 1] > times_[i]; --j) sorted[j] = sorted[j - 1];
      sorted[j] = times_[i];
    }
    return sorted[count_ / 2];
  }

 private:
  std::array<double, kCapacity> times_{};
  int count_ = 0, next_ = 0;
};

class LoadPolicy {
 public:
  /// Frames of a trial of the other way, the frames before the first trial, and the shortest and
  /// the longest gap between trials.
  static constexpr int kTrialFrames = 3, kFirstTrial = 3, kFirstGap = 16, kLongestGap = 256;
  /// Frames of the way that runs whose median may call a trial before its gap ends.
  static constexpr int kEarlyFrames = 5;
  static_assert(kFirstTrial + kTrialFrames == MatcherOptions::kFramesToFirstChoice, "the documented schedule");

  /// Whether the next frame runs on the threads.
  bool use_threads() const { return trial_left_ > 0 ? !threads_best_ : threads_best_; }

  /// After a frame: whether it ran on the threads, and its wall time.
  void record(bool on_threads, double frame_ms) {
    RecentTimes& mine = on_threads ? threads_ : alone_;
    if (trial_left_ > 0) {
      // A trial's time is of its own frames: the way's earlier frames may be from long ago.
      if (trial_left_ == kTrialFrames) mine.clear();
      mine.push(frame_ms);
      if (--trial_left_ > 0) return;
      const bool threads_faster = threads_.median() <= alone_.median();
      gap_ = threads_faster == threads_best_ ? std::min(2 * gap_, kLongestGap) : kFirstGap;
      threads_best_ = threads_faster;
      until_trial_ = gap_;
      return;
    }
    mine.push(frame_ms);
    --until_trial_;
    const int since_trial = gap_ - until_trial_;  // frames since the last trial ended
    const RecentTimes& other = on_threads ? alone_ : threads_;
    const bool slower_than_other = other.count() > 0 && mine.count() >= kEarlyFrames && since_trial >= kFirstGap &&
                                   mine.median() > other.median();
    if (until_trial_ == 0 || slower_than_other) trial_left_ = kTrialFrames;
  }

  /// Frames until the next trial of the other way that the schedule sets (0 during one).
  int frames_to_trial() const { return trial_left_ > 0 ? 0 : until_trial_; }

 private:
  RecentTimes threads_, alone_;
  bool threads_best_ = true;
  int gap_ = kFirstGap, until_trial_ = kFirstTrial, trial_left_ = 0;
};

}  // namespace mctstereo::detail::cpu
