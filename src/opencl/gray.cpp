// to_gray on the device: kernels/gray.cl, specialised by the bytes and weights of the pixel format.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

// The weights of the bytes of a pixel in memory order; they sum to 256.
const char* gray_options(PixelFormat format) {
  if (format == PixelFormat::Rgb8) return "-DBYTES_PER_PIXEL=3 -DWEIGHT_0=77 -DWEIGHT_1=150 -DWEIGHT_2=29";
  if (format == PixelFormat::Bgr8) return "-DBYTES_PER_PIXEL=3 -DWEIGHT_0=29 -DWEIGHT_1=150 -DWEIGHT_2=77";
  return "-DBYTES_PER_PIXEL=1";
}

}  // namespace

ToGray::ToGray(Runtime& rt, PixelFormat format)
    : StageKernel(rt, "gray", "to_gray", gray_options(format)), format_(format) {}

void ToGray::run(const DeviceImage& src, DevicePlane<std::uint8_t>& dst) {
  if (src.format != format_) throw std::invalid_argument("to_gray: the image is not in the stage's pixel format");
  if (dst.width != src.width || dst.height != src.height)
    throw std::invalid_argument("to_gray: the luma plane is " + std::to_string(dst.width) + " x " +
                                std::to_string(dst.height) + ", the image " + std::to_string(src.width) + " x " +
                                std::to_string(src.height));
  if (src.stride < static_cast<std::size_t>(src.width) * bytes_per_pixel(src.format) || src.stride > 0xffffffffu)
    throw std::invalid_argument("to_gray: image stride " + std::to_string(src.stride) + " does not fit its width " +
                                std::to_string(src.width));
  if (src.width == 0 || src.height == 0) return;
  set_args(src.bytes, static_cast<cl_uint>(src.stride), src.width, src.height, dst.buffer, dst.stride);
  enqueue_chunks(src.width, src.height, "gray");
}

void to_gray(Runtime& rt, const DeviceImage& src, DevicePlane<std::uint8_t>& dst) {
  ToGray(rt, src.format).run(src, dst);
}

}  // namespace mctstereo::detail::opencl
