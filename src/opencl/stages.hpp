// The stage list of the opencl backend: the stages of src/stages.hpp on device planes. Each
// function enqueues its kernels on the runtime's in-order queue and returns without waiting; the
// results equal the reference stages bit for bit (tests/opencl/). Buffers are the caller's,
// allocated once per matcher; no stage allocates device memory per call.
#pragma once

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

/// RGB/BGR/gray bytes -> luma plane (reference::to_gray).
void to_gray(Runtime& rt, const DeviceImage& src, DevicePlane<std::uint8_t>& dst);
/// reference::pyramid_down.
void pyramid_down(Runtime& rt, const DevicePlane<std::uint8_t>& src, DevicePlane<std::uint8_t>& dst);
/// reference::census_transform: CT or MCT codes, planar (codes.plane[k] sized like the image).
void census_transform(Runtime& rt, const DevicePlane<std::uint8_t>& image, const CensusConfig& config,
                      DeviceCodes& codes);
/// reference::match with ranges SearchRanges::around(prior, dmin, dmax, radius): the cost and
/// winner-takes-all of the coarsest level (prior == nullptr) or around the prior.
void match(Runtime& rt, const DeviceCodes& ref, const DeviceCodes& other, const DevicePlane<std::int16_t>* prior,
           int dmin, int dmax, int radius, const MatchConfig& config, Popcount popcount,
           DevicePlane<std::int16_t>& disparity);
/// reference::median_filter (k = 3 or 5).
void median_filter(Runtime& rt, const DevicePlane<std::int16_t>& src, int k, DevicePlane<std::int16_t>& dst);
/// reference::lr_check.
void lr_check(Runtime& rt, const DevicePlane<std::int16_t>& src, const DevicePlane<std::int16_t>& other, int dir,
              int threshold_q4, DevicePlane<std::int16_t>& dst);
/// reference::fill_invalid, in place.
void fill_invalid(Runtime& rt, DevicePlane<std::int16_t>& disparity, FillMode mode);
/// reference::upscale.
void upscale(Runtime& rt, const DevicePlane<std::int16_t>& src, int factor, int lo_q4, int hi_q4,
             DevicePlane<std::int16_t>& dst);
/// The caller's conventions: q4 = src with kInvalid replaced by invalid_q4; if `disparity` is not
/// null, disparity = src / 16 as float with NaN for kInvalid (as Matcher's outputs).
void to_output(Runtime& rt, const DevicePlane<std::int16_t>& src, std::int16_t invalid_q4,
               DevicePlane<std::int16_t>& q4, DevicePlane<float>* disparity);

}  // namespace mctstereo::detail::opencl
