#include "peers.hpp"

#include <cmath>

namespace mctstereo::app {

int opencv_num_disparities(int num_disparities) { return (num_disparities + 15) / 16 * 16; }

std::vector<Peer> make_peers(int min_disparity, int num_disparities) {
  const int n = opencv_num_disparities(num_disparities);
  auto bm = cv::StereoBM::create(n, 9);
  bm->setMinDisparity(min_disparity);
  auto sgbm = cv::StereoSGBM::create(min_disparity, n, 5, 8 * 5 * 5, 32 * 5 * 5, 0, 0, 0, 0, 0,
                                     cv::StereoSGBM::MODE_SGBM_3WAY);
  return {{"opencv-stereobm", bm}, {"opencv-stereosgbm", sgbm}};
}

std::string peer_unsupported_reason(const Peer& peer, int width) {
  const int n = peer.matcher->getNumDisparities();
  if (width <= n) return "OpenCV needs a frame wider than its " + std::to_string(n) + " disparities";
  return "";
}

cv::Mat peer_float_disparity(const Peer& peer, const cv::Mat& fixed) {
  // CV_16S, 16 x disparity. Both peers mark a pixel without a match below min_disparity (StereoBM: (min - 1) * 16).
  const float invalid_below = static_cast<float>(peer.matcher->getMinDisparity());
  cv::Mat out(fixed.size(), CV_32F);
  for (int y = 0; y < fixed.rows; ++y) {
    const short* s = fixed.ptr<short>(y);
    float* d = out.ptr<float>(y);
    for (int x = 0; x < fixed.cols; ++x) {
      const float v = static_cast<float>(s[x]) / 16.0f;
      d[x] = v < invalid_below ? NAN : v;
    }
  }
  return out;
}

}  // namespace mctstereo::app
