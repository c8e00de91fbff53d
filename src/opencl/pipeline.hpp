// The driver of the opencl backend: the recipe of src/matcher.cpp on device planes. The Matcher
// checks the input and owns the host maps; this class owns the device, its buffers and the frame.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

/// Every device of list_devices() as the public API describes it.
std::vector<OpenclDevice> describe_devices();

class Pipeline {
 public:
  /// Opens `device` (its runtime is shared with every other pipeline on it), allocates every
  /// device buffer for width x height, makes every stage the parameters use (building their
  /// kernels, or throwing the build log) and runs one frame on a blank pair, so that compute()
  /// only sets kernel arguments and enqueues, and the first frame is timed like any other. The
  /// parameters are valid (the Matcher checked them). std::runtime_error naming the device when
  /// the memory does not suffice or a kernel does not build.
  Pipeline(const DeviceInfo& device, int width, int height, const StereoParams& params,
           const MatcherOptions& options);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Matches one pair (checked by the caller: size, stride, pixels) and downloads the Q4 maps:
  /// q4[0] the left view, q4[1] the right view with compute_right (planes of the image size).
  void compute(const ImageView& left, const ImageView& right, Plane<std::int16_t> (&q4)[2]);
  /// The left map of the last frame in pixels, NaN where invalid (device-made by to_output,
  /// downloaded only when asked for).
  void download_float(Plane<float>& disparity);
  /// The confidence (0..255) of the last frame at the working scale, the size of the finest level
  /// (downloaded only when asked for); band SGM, or box aggregation with compute_confidence.
  void download_confidence(Plane<std::uint8_t>& confidence);

  /// The stage times of the last frame, as Matcher::timings() describes them for opencl (zero
  /// before the first frame).
  const std::vector<StageTime>& timings() const { return timings_; }
  /// "NAME (PLATFORM)".
  std::string device_name() const;
  /// Bytes of device memory the buffers take.
  std::size_t device_bytes() const { return device_bytes_; }
  /// The temporal prior (StereoParams::temporal): the next frame is matched alone.
  void reset_temporal() { temporal_history_ = false; }
  /// The last frame was matched with the temporal prior.
  bool used_temporal_prior() const { return used_previous_; }

 private:
  struct Level;
  struct Stages;
  void allocate();
  const DevicePlane<std::uint8_t>& level_image(int l, int v) const;
  void upload_input(const ImageView& image, int view);
  void allocate_sgm_planes(Level& L);
  void allocate_sgm_storage();
  void run_levels();
  DeviceTemporal temporal_prior(int l, int v) const;
  void take_previous_maps();
  void match_sgm(int l, const DevicePlane<std::int16_t>* prior);
  void refine(Level& L, bool finest);
  void remove_speckles_on_host(Level& L, int view, int speckle);
  void write_outputs();
  template <typename T>
  void plane(DevicePlane<T>& p, int w, int h);

  std::shared_ptr<Runtime> rt_;
  std::mutex* frame_mutex_;  // one per runtime: frames of pipelines sharing a device take turns
  int width_, height_;
  StereoParams params_;
  MatcherOptions options_;
  bool need_right_;
  bool want_confidence_;  // band SGM always, box aggregation when the options ask for it
  Popcount popcount_;
  std::int16_t invalid_q4_;
  std::size_t device_bytes_ = 0;

  DeviceImage input_[2];                               // colour input as the caller's bytes, packed rows
  std::vector<DevicePlane<std::uint8_t>> full_gray_[2];  // input size, then each working-scale reduction
  // Colour-weighted median: the left view's channels at the input size and each working-scale
  // reduction (colour input), and the colour the frame gives the stage.
  std::vector<std::array<DevicePlane<std::uint8_t>, 3>> full_colour_;
  DeviceColour wm_colour_;
  bool colour_input_ = false;
  std::vector<Level> levels_;                            // levels_[0] is the finest (working scale)
  std::unique_ptr<Stages> stages_;                       // made once; matching's are the levels' own
  DevicePlane<std::int16_t> upscaled_[2], out_q4_[2];
  DevicePlane<float> out_float_;
  // The margins of the plan's margin_level and the finest level's confidence, when want_confidence_.
  int margin_level_ = 0;
  DevicePlane<std::uint8_t> margin_, confidence_;
  // The left map's partners beside the right map (StereoParams::lr_check_grid, with the right map
  // asked for).
  DevicePlane<std::int16_t> grid_partners_;
  SpeckleScratch speckle_scratch_;  // speckle removal runs on the host
  double speckle_ms_ = 0;
  std::vector<StageTime> timings_;  // filled in place: a frame only changes the times
  // The temporal prior: the levels' maps of the last frame can serve the next one (none after
  // construction, whose blank frame does not count, and reset_temporal()), and the last frame
  // was matched with them.
  bool temporal_history_ = false;
  bool used_previous_ = false;
};

}  // namespace mctstereo::detail::opencl
