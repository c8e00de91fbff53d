// The OpenCV matchers that every comparison table sets mctstereo against, configured once here so
// that `eval` and `bench` measure the same peers.
#pragma once

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace mctstereo::app {

struct Peer {
  std::string name;  ///< "opencv-stereobm", "opencv-stereosgbm"
  cv::Ptr<cv::StereoMatcher> matcher;
};

/// OpenCV searches a multiple of 16 disparities: `num_disparities` rounded up to one.
int opencv_num_disparities(int num_disparities);

/// StereoBM (blockSize 9) and StereoSGBM (blockSize 5, MODE_SGBM_3WAY, P1 = 8*5*5, P2 = 32*5*5),
/// searching min_disparity .. min_disparity + opencv_num_disparities(num_disparities) - 1.
std::vector<Peer> make_peers(int min_disparity, int num_disparities);

/// Why `peer` cannot match frames `width` wide (OpenCV 4.6's StereoSGBM throws when the frame is
/// as narrow as its range and crashes when narrower), or "" when it can.
std::string peer_unsupported_reason(const Peer& peer, int width);

/// The peer's disparity in pixels (CV_32F), NaN where it found none, from its CV_16S map `fixed`.
cv::Mat peer_float_disparity(const Peer& peer, const cv::Mat& fixed);

}  // namespace mctstereo::app
