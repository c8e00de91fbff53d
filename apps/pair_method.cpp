#include "pair_method.hpp"

#include <chrono>
#include <cmath>
#include <utility>

#include "io.hpp"

namespace mctstereo::app {

namespace {

// Q4 disparities of a float map (not finite = invalid), for encode_preview.
cv::Mat to_q4(MapView<const float> d, std::int16_t invalid_q4) {
  cv::Mat q4(d.height, d.width, CV_16S);
  for (int y = 0; y < d.height; ++y) {
    const float* src = d.row(y);
    std::int16_t* dst = q4.ptr<std::int16_t>(y);
    for (int x = 0; x < d.width; ++x)
      dst[x] = std::isfinite(src[x]) ? static_cast<std::int16_t>(std::lround(src[x] * kDisparityScale)) : invalid_q4;
  }
  return q4;
}

}  // namespace

PresetMethod::PresetMethod(Matcher matcher) : matcher_(std::move(matcher)) {
  min_disparity = matcher_.params().min_disparity;
  num_disparities = matcher_.params().num_disparities;
}

void PresetMethod::compute(const PairViews& views) { matcher_.compute(image_view(views.left), image_view(views.right)); }

double PresetMethod::frame_ms() const { return matcher_.timings().back().ms; }

MapView<const float> PresetMethod::disparity() { return matcher_.disparity(); }

MapView<const float> PresetMethod::confidence() const { return matcher_.confidence(); }

std::vector<std::uint8_t> PresetMethod::preview(const std::string& path) {
  return encode_preview(matcher_.disparity_q4(), matcher_.invalid_q4(), min_disparity,
                        matcher_.params().max_disparity(), path);
}

PeerMethod::PeerMethod(Peer peer, int min, int range) : peer_(std::move(peer)), range_(range) {
  min_disparity = min;
  num_disparities = peer_.matcher->getNumDisparities();
}

void PeerMethod::compute(const PairViews& views) {
  const auto start = std::chrono::steady_clock::now();
  peer_.matcher->compute(views.left_gray, views.right_gray, fixed_);
  ms_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  converted_ = false;
}

MapView<const float> PeerMethod::disparity() {
  if (!converted_) {
    estimate_ = peer_float_disparity(peer_, fixed_);
    converted_ = true;
  }
  return {estimate_.ptr<const float>(0), estimate_.cols, estimate_.rows,
          static_cast<std::ptrdiff_t>(estimate_.step[0] / sizeof(float))};
}

std::vector<std::uint8_t> PeerMethod::preview(const std::string& path) {
  const auto invalid = static_cast<std::int16_t>((min_disparity - 1) * kDisparityScale);
  const cv::Mat q4 = to_q4(disparity(), invalid);
  const MapView<const std::int16_t> view{q4.ptr<const std::int16_t>(0), q4.cols, q4.rows,
                                         static_cast<std::ptrdiff_t>(q4.step[0] / sizeof(std::int16_t))};
  return encode_preview(view, invalid, min_disparity, min_disparity + range_ - 1, path);
}

}  // namespace mctstereo::app
