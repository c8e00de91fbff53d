// Whether a frame of the cpu backend runs on the matcher's threads or on the caller's thread alone
// (MatcherOptions::adapt_threads).
//
// The pool hands out small chunks and never waits for a thread that has not started one, but a
// worker that the OS takes off the CPU in the middle of a chunk holds up the end of its stage for
// the rest of a scheduler time slice (milliseconds), and a waiting thread spends its own share of
// the CPU polling. On a CPU that other processes keep busy that happens at stage after stage, and
// 2 threads ran slower than 1 (bench --load 2). So the matcher keeps the mean frame time of each
// way, runs its frames the faster way, and tries the other way for a few frames now and then: after
// 16 frames, and after twice as many each time the trial confirms the choice (at most 256), so
// that on an idle machine the trials cost little. The maps do not depend on it: every stage is
// bit-exact for any thread count.
#pragma once

#include <algorithm>

namespace mctstereo::detail::cpu {

class LoadPolicy {
 public:
  /// Weight of a new frame in the mean time of the way it ran.
  static constexpr double kWeight = 0.25;
  /// Frames of a trial of the other way, and the first and the longest gap between trials.
  static constexpr int kTrialFrames = 2, kFirstGap = 16, kLongestGap = 256;

  /// Whether the next frame runs on the threads.
  bool use_threads() const { return trial_left_ > 0 ? !threads_best_ : threads_best_; }

  /// After a frame: whether it ran on the threads, and its wall time.
  void record(bool on_threads, double frame_ms) {
    if (trial_left_ > 0) {
      // A trial's mean is of its own frames: the other way's mean may be from long ago.
      trial_sum_ += frame_ms;
      if (--trial_left_ > 0) return;
      (on_threads ? threads_ms_ : alone_ms_) = trial_sum_ / kTrialFrames;
      const bool threads_faster = threads_ms_ <= alone_ms_;
      gap_ = threads_faster == threads_best_ ? std::min(2 * gap_, kLongestGap) : kFirstGap;
      threads_best_ = threads_faster;
      until_trial_ = gap_;
      return;
    }
    double& mean = on_threads ? threads_ms_ : alone_ms_;
    mean = mean < 0 ? frame_ms : mean + kWeight * (frame_ms - mean);
    if (--until_trial_ == 0) {
      trial_left_ = kTrialFrames;
      trial_sum_ = 0;
    }
  }

  /// Frames until the next trial of the other way (0 during one).
  int frames_to_trial() const { return trial_left_ > 0 ? 0 : until_trial_; }

 private:
  double threads_ms_ = -1, alone_ms_ = -1;  // mean frame times; -1: none yet
  bool threads_best_ = true;
  int gap_ = kFirstGap, until_trial_ = kFirstGap, trial_left_ = 0;
  double trial_sum_ = 0;
};

}  // namespace mctstereo::detail::cpu
