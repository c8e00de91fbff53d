// A method that matches a pair: a preset of the library or one of OpenCV's matchers. `eval` scores
// the maps and `bench` times compute() through this one interface, so both run the presets and the
// peers the same way.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "peers.hpp"

namespace mctstereo::app {

/// The views of one pair as the methods take them: the images as read (colour or gray) for the
/// presets, their 8-bit gray forms for OpenCV's matchers (which take gray frames only).
struct PairViews {
  const cv::Mat& left;
  const cv::Mat& right;
  const cv::Mat& left_gray;
  const cv::Mat& right_gray;
};

class PairMethod {
 public:
  virtual ~PairMethod() = default;
  /// Matches the pair: the work `bench` times, and nothing else.
  virtual void compute(const PairViews& views) = 0;
  /// The last pair's frame time in ms: the library's own (Matcher::timings) for a preset, the wall
  /// time of compute() for OpenCV.
  virtual double frame_ms() const = 0;
  /// The last pair's disparity in pixels (not finite where there is none), made by the first call
  /// after compute(); valid until the next compute().
  virtual MapView<const float> disparity() = 0;
  /// The last pair's confidence; null data for a method without one.
  virtual MapView<const float> confidence() const { return {}; }
  /// The colour preview of the last pair over the method's range, encoded for `path`.
  virtual std::vector<std::uint8_t> preview(const std::string& path) = 0;

  int min_disparity = 0, num_disparities = 0;  ///< the range it searches
};

/// A preset (or any parameters) through the library.
class PresetMethod final : public PairMethod {
 public:
  explicit PresetMethod(Matcher matcher);
  void compute(const PairViews& views) override;
  double frame_ms() const override;
  MapView<const float> disparity() override;
  MapView<const float> confidence() const override;
  std::vector<std::uint8_t> preview(const std::string& path) override;
  const Matcher& matcher() const { return matcher_; }

 private:
  Matcher matcher_;
};

/// One of OpenCV's matchers (peers.hpp) on the gray views.
class PeerMethod final : public PairMethod {
 public:
  /// `range`: the disparities asked for; OpenCV searches a multiple of 16 of them
  /// (num_disparities), the preview shows the range asked for.
  PeerMethod(Peer peer, int min_disparity, int range);
  void compute(const PairViews& views) override;
  double frame_ms() const override { return ms_; }
  MapView<const float> disparity() override;
  std::vector<std::uint8_t> preview(const std::string& path) override;
  const Peer& peer() const { return peer_; }

 private:
  Peer peer_;
  int range_;
  cv::Mat fixed_;     // OpenCV's CV_16S map of the last pair
  cv::Mat estimate_;  // its disparity in pixels, made on demand
  bool converted_ = false;
  double ms_ = 0.0;
};

}  // namespace mctstereo::app
