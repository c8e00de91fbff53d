// reference::weighted_median and split_channels on the device: kernels/weighted_median.cl.
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

SplitChannels::SplitChannels(Runtime& rt) : StageKernel(rt, "weighted_median", "split_channels", "") {}

void SplitChannels::run(const DeviceImage& src, std::array<DevicePlane<std::uint8_t>, 3>& dst) {
  if (src.format == PixelFormat::Gray8) throw std::invalid_argument("split_channels: the image has one channel");
  for (const auto& p : dst)
    if (p.width != src.width || p.height != src.height || p.stride != dst[0].stride)
      throw std::invalid_argument("split_channels: the channel planes are not " + std::to_string(src.width) + " x " +
                                  std::to_string(src.height) + " with one stride");
  if (src.width == 0 || src.height == 0) return;
  set_args(src.bytes, static_cast<cl_uint>(src.stride), src.width, src.height, dst[0].buffer, dst[1].buffer,
           dst[2].buffer, dst[0].stride);
  enqueue_chunks(src.width, src.height, "gray");
}

WeightedMedian::WeightedMedian(Runtime& rt, const WeightedMedianConfig& config)
    : StageKernel(rt, "weighted_median", "weighted_median", ""),
      reach_(config.radius / config.step * config.step),
      step_(config.step) {
  if (config.step < 1 || config.radius < 1)
    throw std::invalid_argument("weighted_median: radius " + std::to_string(config.radius) + " and step " +
                                std::to_string(config.step) + " must be at least 1");
  lut_ = rt.buffer(config.lut.size(), CL_MEM_READ_ONLY);
  rt.queue().enqueueWriteBuffer(lut_, CL_TRUE, 0, config.lut.size(), config.lut.data());
}

void WeightedMedian::run(const DevicePlane<std::int16_t>& src, const DeviceColour& colour,
                         DevicePlane<std::int16_t>& dst) {
  if (dst.width != src.width || dst.height != src.height)
    throw std::invalid_argument("weighted_median: destination " + std::to_string(dst.width) + "x" +
                                std::to_string(dst.height) + " differs from the source " + std::to_string(src.width) +
                                "x" + std::to_string(src.height));
  if (colour.channels != 1 && colour.channels != 3) throw std::invalid_argument("weighted_median: 1 or 3 channels");
  for (int c = 0; c < colour.channels; ++c)
    if (colour.plane[c] == nullptr || colour.plane[c]->width != src.width || colour.plane[c]->height != src.height ||
        colour.plane[c]->stride != colour.plane[0]->stride)
      throw std::invalid_argument("weighted_median: the colour planes are not the map's size with one stride");
  if (src.width == 0 || src.height == 0) return;
  const DevicePlane<std::uint8_t>& p0 = *colour.plane[0];
  const DevicePlane<std::uint8_t>& p1 = colour.channels == 3 ? *colour.plane[1] : p0;
  const DevicePlane<std::uint8_t>& p2 = colour.channels == 3 ? *colour.plane[2] : p0;
  set_args(src.buffer, src.stride, p0.buffer, p1.buffer, p2.buffer, p0.stride, colour.channels, lut_, reach_, step_,
           dst.buffer, dst.stride, src.width, src.height);
  enqueue_chunks(src.width, src.height, "weighted_median");
}

void split_channels(Runtime& rt, const DeviceImage& src, std::array<DevicePlane<std::uint8_t>, 3>& dst) {
  SplitChannels(rt).run(src, dst);
}

void weighted_median(Runtime& rt, const DevicePlane<std::int16_t>& src, const DeviceColour& colour,
                     const WeightedMedianConfig& config, DevicePlane<std::int16_t>& dst) {
  WeightedMedian(rt, config).run(src, colour, dst);
}

}  // namespace mctstereo::detail::opencl
