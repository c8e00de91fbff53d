// to_gray on the device: kernels/gray.cl, specialised by the bytes and weights of the pixel format.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

// Work-groups of 16 x 4 work-items, each work-item 16 pixels of a row: a fixed size, so that
// drivers that compile per work-group size (PoCL) compile each program once; the kernels skip the
// work-items past the plane.
cl::NDRange global_for(int chunks, int rows) { return cl::NDRange((chunks + 15) / 16 * 16, (rows + 3) / 4 * 4); }
const cl::NDRange kLocal(16, 4);

}  // namespace

void to_gray(Runtime& rt, const DeviceImage& src, DevicePlane<std::uint8_t>& dst) {
  if (dst.width != src.width || dst.height != src.height)
    throw std::invalid_argument("to_gray: the luma plane is " + std::to_string(dst.width) + " x " +
                                std::to_string(dst.height) + ", the image " + std::to_string(src.width) + " x " +
                                std::to_string(src.height));
  if (src.stride < static_cast<std::size_t>(src.width) * bytes_per_pixel(src.format) || src.stride > 0xffffffffu)
    throw std::invalid_argument("to_gray: image stride " + std::to_string(src.stride) + " does not fit its width " +
                                std::to_string(src.width));
  if (src.width == 0 || src.height == 0) return;
  // The weights of the bytes of a pixel in memory order; they sum to 256.
  const char* options = "-DBYTES_PER_PIXEL=1";
  if (src.format == PixelFormat::Rgb8) options = "-DBYTES_PER_PIXEL=3 -DWEIGHT_0=77 -DWEIGHT_1=150 -DWEIGHT_2=29";
  if (src.format == PixelFormat::Bgr8) options = "-DBYTES_PER_PIXEL=3 -DWEIGHT_0=29 -DWEIGHT_1=150 -DWEIGHT_2=77";
  cl::Kernel kernel = rt.kernel("gray", "to_gray", options);
  kernel.setArg(0, src.bytes);
  kernel.setArg(1, static_cast<cl_uint>(src.stride));
  kernel.setArg(2, src.width);
  kernel.setArg(3, src.height);
  kernel.setArg(4, dst.buffer);
  kernel.setArg(5, dst.stride);
  rt.run(kernel, global_for((src.width + 15) / 16, src.height), kLocal, "gray");
}

}  // namespace mctstereo::detail::opencl
