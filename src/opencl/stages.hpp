// The stage list of the opencl backend: the stages of src/stages.hpp on device planes. Each
// stage enqueues its kernels on the runtime's in-order queue and returns without waiting; the
// results equal the reference stages bit for bit (tests/opencl/). Buffers are the caller's,
// allocated once per matcher; no stage allocates device memory per call.
//
// A stage is an object made once with the settings that select its kernel program: making it
// builds the program (once per runtime and option set) and creates the kernel. run() then checks
// the planes, sets the kernel's arguments and enqueues it, and allocates nothing on the host, so
// the pipeline makes every stage it needs when it is constructed and a frame only runs them. The
// free functions after the classes make a stage for one call (tests, one-off use).
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <tuple>

#include "opencl/runtime.hpp"
#include "../stages.hpp"  // src/stages.hpp (a plain "stages.hpp" would name this file)

namespace mctstereo::detail::opencl {

/// How kernels count bits: the popcount built-in (OpenCL C 1.2) or the SWAR form (OpenCL 1.1
/// devices). Both are kept and tested. pick_popcount() takes the built-in on GPUs that have it
/// (one instruction there) and SWAR elsewhere: PoCL runs the built-in lane by lane but turns the
/// SWAR form into vector code, 1.5 to 2.3 x faster in the matching kernel (640 x 480, measured).
enum class Popcount { Builtin, Swar };
inline Popcount pick_popcount(const DeviceInfo& device) {
  return device.has_popcount && device.gpu ? Popcount::Builtin : Popcount::Swar;
}

/// An input image as uploaded: the caller's bytes (rows `stride` bytes apart) in `bytes`.
struct DeviceImage {
  cl::Buffer bytes;
  int width = 0, height = 0;
  std::size_t stride = 0;
  PixelFormat format = PixelFormat::Gray8;
};

/// A `__global` pointer argument given no buffer: the kernel is told not to touch it.
struct NoBuffer {};

/// The temporal prior of one view at one level (TemporalPrior of src/stages.hpp) on the device:
/// the view's map of the previous frame at the level, the level's gray image now and then.
struct DeviceTemporal {
  const DevicePlane<std::int16_t>* map = nullptr;
  const DevicePlane<std::uint8_t>* image = nullptr;
  const DevicePlane<std::uint8_t>* previous_image = nullptr;
  int radius = 0, threshold = 0;
};

/// std::invalid_argument naming `stage` unless the temporal prior's planes are all w x h.
inline void check_temporal(const char* stage, const DeviceTemporal& t, int w, int h) {
  if (t.map == nullptr || t.image == nullptr || t.previous_image == nullptr)
    throw std::invalid_argument(std::string(stage) + ": a temporal prior without its map or images");
  for (const auto& [what, pw, ph] : {std::tuple{"previous map", t.map->width, t.map->height},
                                     std::tuple{"image", t.image->width, t.image->height},
                                     std::tuple{"previous image", t.previous_image->width, t.previous_image->height}})
    if (pw != w || ph != h)
      throw std::invalid_argument(std::string(stage) + ": the temporal prior's " + what + " is " + std::to_string(pw) +
                                  " x " + std::to_string(ph) + " for a level of " + std::to_string(w) + " x " +
                                  std::to_string(h));
}

/// What every stage holds: its runtime and its kernel. OpenCL takes a kernel's argument values
/// when it is enqueued, so one kernel object serves every call of a frame (each level, each view).
class StageKernel {
 protected:
  /// No kernel (a stage with nothing to do in its configuration).
  explicit StageKernel(Runtime& rt) : rt_(&rt) {}
  /// Kernel `name` of kernel file `file` built with `options` (Runtime::kernel).
  StageKernel(Runtime& rt, std::string_view file, std::string_view name, const std::string& options)
      : rt_(&rt), kernel_(rt.kernel(file, name, options)) {}

  /// Sets the kernel's arguments, from `first` on, to `args`.
  template <typename... Args>
  void set_args_from(cl_uint first, const Args&... args) {
    cl_uint index = first;
    (set_arg(index++, args), ...);
  }
  template <typename... Args>
  void set_args(const Args&... args) {
    set_args_from(0, args...);
  }
  /// The temporal prior's arguments from `first` on (map, its stride, image, its stride, previous
  /// image, its stride, radius, threshold); null: a null map (no prior).
  void set_temporal_args(cl_uint first, const DeviceTemporal* t) {
    if (t == nullptr) {
      set_args_from(first, NoBuffer{}, 0, NoBuffer{}, 0, NoBuffer{}, 0, 0, 0);
      return;
    }
    set_args_from(first, t->map->buffer, t->map->stride, t->image->buffer, t->image->stride,
                  t->previous_image->buffer, t->previous_image->stride, t->radius, t->threshold);
  }
  /// Enqueues the kernel over `global` in work-groups of `local`.
  void enqueue(const cl::NDRange& global, const cl::NDRange& local, const char* label) {
    rt_->run(kernel_, global, local, label);
  }
  /// Enqueues the kernel over a width x height plane, a work-item per 16 pixels of a row, in
  /// work-groups of 16 x 4 work-items; the range is rounded up to whole groups and the kernels
  /// skip the work-items past the plane. 64 work-items fill whole SIMD groups of 32 or 64 on GPUs,
  /// and one fixed shape means one compiled work-group function on CPU drivers that compile one
  /// per local size (PoCL), where a driver-chosen size would differ with the plane size.
  void enqueue_chunks(int width, int height, const char* label) {
    const int chunks = (width + 15) / 16;
    enqueue(cl::NDRange((chunks + 15) / 16 * 16, (height + 3) / 4 * 4), cl::NDRange(16, 4), label);
  }

  Runtime* rt_;
  cl::Kernel kernel_;

 private:
  template <typename T>
  void set_arg(cl_uint index, const T& value) {
    kernel_.setArg(index, value);
  }
  void set_arg(cl_uint index, NoBuffer) { kernel_.setArg(index, sizeof(cl_mem), nullptr); }
};

/// RGB/BGR/gray bytes of one pixel format -> luma plane (reference::to_gray).
class ToGray : StageKernel {
 public:
  ToGray(Runtime& rt, PixelFormat format);
  void run(const DeviceImage& src, DevicePlane<std::uint8_t>& dst);

 private:
  PixelFormat format_;
};

/// reference::pyramid_down.
class PyramidDown : StageKernel {
 public:
  explicit PyramidDown(Runtime& rt);
  void run(const DevicePlane<std::uint8_t>& src, DevicePlane<std::uint8_t>& dst);
};

/// reference::census_transform: CT or MCT codes, planar (codes.plane[k] sized like the image).
class CensusTransform : StageKernel {
 public:
  CensusTransform(Runtime& rt, const CensusConfig& config);
  void run(const DevicePlane<std::uint8_t>& image, DeviceCodes& codes);

 private:
  int window_;
};

/// reference::match with ranges SearchRanges::around(prior, dmin, dmax, radius): the cost and
/// winner-takes-all of the coarsest level (prior == nullptr) or around the prior. One kernel per
/// census word count, SHD window, sub-pixel and uniqueness on or off (config.dir aside: both views
/// share it, run() takes the direction), popcount form and work layout (a GPU's or a CPU
/// device's, whatever the device is: tests run both).
class Match : StageKernel {
 public:
  /// margin: the kernel can also write the winners' margins (reference::match's margin).
  Match(Runtime& rt, int code_words, const MatchConfig& config, bool margin, Popcount popcount, bool gpu_layout);
  /// temporal: the temporal prior around the previous frame's map (used only with a prior), or null.
  void run(const DeviceCodes& ref, const DeviceCodes& other, const DevicePlane<std::int16_t>* prior, int dmin,
           int dmax, int radius, int dir, DevicePlane<std::int16_t>& disparity,
           DevicePlane<std::uint8_t>* margin = nullptr, const DeviceTemporal* temporal = nullptr);

 private:
  int code_words_;
  MatchConfig config_;
  bool margin_;
  int rows_;  // image rows per work-item
  cl::NDRange local_;
};

/// reference::median_filter (k = 3 or 5).
class MedianFilter : StageKernel {
 public:
  MedianFilter(Runtime& rt, int k);
  void run(const DevicePlane<std::int16_t>& src, DevicePlane<std::int16_t>& dst);
};

/// reference::grid_partner (median size 0, 3 or 5).
class GridPartner : StageKernel {
 public:
  GridPartner(Runtime& rt, int median_size);
  void run(const DevicePlane<std::int16_t>& right, DevicePlane<std::int16_t>& partner);
};

/// reference::lr_check of one direction.
class LrCheck : StageKernel {
 public:
  LrCheck(Runtime& rt, int dir);
  void run(const DevicePlane<std::int16_t>& src, const DevicePlane<std::int16_t>& other, int threshold_q4,
           DevicePlane<std::int16_t>& dst);
};

/// reference::fill_invalid, in place (FillMode::None makes no kernel and does nothing).
class FillInvalid : StageKernel {
 public:
  FillInvalid(Runtime& rt, FillMode mode);
  void run(DevicePlane<std::int16_t>& disparity);

 private:
  FillMode mode_;
};

/// reference::upscale.
class Upscale : StageKernel {
 public:
  Upscale(Runtime& rt, int factor);
  void run(const DevicePlane<std::int16_t>& src, int lo_q4, int hi_q4, DevicePlane<std::int16_t>& dst);

 private:
  int factor_;
};

/// The caller's conventions: q4 = src with kInvalid replaced by invalid_q4; with_float also makes
/// disparity = src / 16 as float with NaN for kInvalid (as Matcher's outputs).
class ToOutput : StageKernel {
 public:
  ToOutput(Runtime& rt, bool with_float);
  /// `disparity` is written with with_float and must then not be null; it is ignored without.
  void run(const DevicePlane<std::int16_t>& src, std::int16_t invalid_q4, DevicePlane<std::int16_t>& q4,
           DevicePlane<float>* disparity);

 private:
  bool with_float_;
};

/// A level's band SGM volume on the device, as SgmVolume: lo and count planes of the level, and
/// the cost and sum entries ((y W + x) stride per pixel) in buffers the caller owns and shares
/// between the levels (sized for the largest), with the aggregation's line scratch.
struct DeviceSgmVolume {
  int width = 0, height = 0;
  int band = 0;    ///< most candidates of a pixel at this level
  int stride = 0;  ///< entries per pixel slot: SgmVolume::stride_for(band)
  DevicePlane<std::int16_t> lo, count;
  cl::Buffer cost, sum;
  /// The costs are bytes (SgmVolume::use_byte_costs(): every cost of the level below 255).
  bool byte_costs = false;
  cl::Buffer scratch;  ///< sgm_aggregate: 2 x stride entries per path line
  /// Entries of the line scratch for a level.
  static std::size_t scratch_entries_for(int w, int h, int band_width) {
    return static_cast<std::size_t>(w + h) * 2 * SgmVolume::stride_for(band_width);
  }
};

/// reference::sgm_costs: each pixel's band around the coarser map and its SHD costs.
class SgmCosts : StageKernel {
 public:
  SgmCosts(Runtime& rt, Popcount popcount);
  /// prior == nullptr: the whole range (the coarsest level). temporal: the left view's temporal
  /// prior (used only with a prior), or null; config.temporal (host planes) is not read.
  void run(const DeviceCodes& left, const DeviceCodes& right, const DevicePlane<std::int16_t>* prior,
           const SgmBandConfig& config, int shd_window, DeviceSgmVolume& volume,
           const DeviceTemporal* temporal = nullptr);
};

/// reference::sgm_aggregate: one enqueue per path direction, a work-item per path line.
class SgmAggregate : StageKernel {
 public:
  explicit SgmAggregate(Runtime& rt);
  void run(const DevicePlane<std::uint8_t>& gray, const SgmPathConfig& config, DeviceSgmVolume& volume);
};

/// reference::sgm_select: the left map (margins when margin != nullptr), the right map from the
/// same sums when right != nullptr. dmin, dmax: the level range (every band lies inside it).
class SgmSelect {
 public:
  explicit SgmSelect(Runtime& rt);
  ~SgmSelect();
  void run(const DeviceSgmVolume& volume, const SgmSelectConfig& config, int dmin, int dmax,
           DevicePlane<std::int16_t>& left, DevicePlane<std::int16_t>* right, DevicePlane<std::uint8_t>* margin);

 private:
  class Left;
  class Right;
  std::unique_ptr<Left> left_;
  std::unique_ptr<Right> right_;
};

/// reference::confidence.
class Confidence : StageKernel {
 public:
  explicit Confidence(Runtime& rt);
  /// margin: 2^margin_shift times smaller than the map (reference::confidence).
  void run(const DevicePlane<std::uint8_t>& margin, int margin_shift, const DevicePlane<std::int16_t>& checked,
           const DevicePlane<std::int16_t>* right, int threshold, DevicePlane<std::uint8_t>& dst);
};

/// reference::split_channels of colour input (RGB or BGR bytes as uploaded) into three planes.
class SplitChannels : StageKernel {
 public:
  explicit SplitChannels(Runtime& rt);
  void run(const DeviceImage& src, std::array<DevicePlane<std::uint8_t>, 3>& dst);
};

/// The colour of a level for the weighted median on the device: `channels` (1 or 3) planes of
/// the level's size (a gray input's plane three times over when 1).
struct DeviceColour {
  int channels = 1;
  const DevicePlane<std::uint8_t>* plane[3] = {nullptr, nullptr, nullptr};
};

/// reference::weighted_median. The table (config.lut, built on the host) is uploaded once when
/// the stage is made.
class WeightedMedian : StageKernel {
 public:
  WeightedMedian(Runtime& rt, const WeightedMedianConfig& config);
  void run(const DevicePlane<std::int16_t>& src, const DeviceColour& colour, DevicePlane<std::int16_t>& dst);

 private:
  int reach_, step_;
  cl::Buffer lut_;
};

// One call each: the stage made for it, then run.
void to_gray(Runtime& rt, const DeviceImage& src, DevicePlane<std::uint8_t>& dst);
void pyramid_down(Runtime& rt, const DevicePlane<std::uint8_t>& src, DevicePlane<std::uint8_t>& dst);
void census_transform(Runtime& rt, const DevicePlane<std::uint8_t>& image, const CensusConfig& config,
                      DeviceCodes& codes);
/// With the work layout of the device (a GPU's or a CPU device's).
void match(Runtime& rt, const DeviceCodes& ref, const DeviceCodes& other, const DevicePlane<std::int16_t>* prior,
           int dmin, int dmax, int radius, const MatchConfig& config, Popcount popcount,
           DevicePlane<std::int16_t>& disparity, DevicePlane<std::uint8_t>* margin = nullptr,
           const DeviceTemporal* temporal = nullptr);
void median_filter(Runtime& rt, const DevicePlane<std::int16_t>& src, int k, DevicePlane<std::int16_t>& dst);
void grid_partner(Runtime& rt, const DevicePlane<std::int16_t>& right, int median_size,
                  DevicePlane<std::int16_t>& partner);
void lr_check(Runtime& rt, const DevicePlane<std::int16_t>& src, const DevicePlane<std::int16_t>& other, int dir,
              int threshold_q4, DevicePlane<std::int16_t>& dst);
void fill_invalid(Runtime& rt, DevicePlane<std::int16_t>& disparity, FillMode mode);
void upscale(Runtime& rt, const DevicePlane<std::int16_t>& src, int factor, int lo_q4, int hi_q4,
             DevicePlane<std::int16_t>& dst);
void split_channels(Runtime& rt, const DeviceImage& src, std::array<DevicePlane<std::uint8_t>, 3>& dst);
void weighted_median(Runtime& rt, const DevicePlane<std::int16_t>& src, const DeviceColour& colour,
                     const WeightedMedianConfig& config, DevicePlane<std::int16_t>& dst);
/// The float map is made when `disparity` is not null.
void to_output(Runtime& rt, const DevicePlane<std::int16_t>& src, std::int16_t invalid_q4,
               DevicePlane<std::int16_t>& q4, DevicePlane<float>* disparity);

}  // namespace mctstereo::detail::opencl
