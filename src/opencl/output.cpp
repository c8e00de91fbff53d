// The caller's conventions on the device: kernels/output.cl, with or without the float map.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

ToOutput::ToOutput(Runtime& rt, bool with_float)
    : StageKernel(rt, "output", "to_output", with_float ? "-DWITH_FLOAT=1" : "-DWITH_FLOAT=0"),
      with_float_(with_float) {}

void ToOutput::run(const DevicePlane<std::int16_t>& src, std::int16_t invalid_q4, DevicePlane<std::int16_t>& q4,
                   DevicePlane<float>* disparity) {
  if (with_float_ && disparity == nullptr) throw std::invalid_argument("to_output: no float map to write");
  const auto same_size = [&](int w, int h) { return w == src.width && h == src.height; };
  if (!same_size(q4.width, q4.height) || (with_float_ && !same_size(disparity->width, disparity->height)))
    throw std::invalid_argument("to_output: the output maps differ in size from the " + std::to_string(src.width) +
                                "x" + std::to_string(src.height) + " map");
  if (src.width == 0 || src.height == 0) return;
  set_args(src.buffer, src.stride, static_cast<cl_int>(invalid_q4), q4.buffer, q4.stride);
  if (with_float_)
    set_args_from(5, disparity->buffer, disparity->stride);
  else
    set_args_from(5, NoBuffer{}, 0);  // the kernel does not touch it
  set_args_from(7, src.width, src.height);
  enqueue_chunks(src.width, src.height, "output");
}

void to_output(Runtime& rt, const DevicePlane<std::int16_t>& src, std::int16_t invalid_q4,
               DevicePlane<std::int16_t>& q4, DevicePlane<float>* disparity) {
  ToOutput(rt, disparity != nullptr).run(src, invalid_q4, q4, disparity);
}

}  // namespace mctstereo::detail::opencl
