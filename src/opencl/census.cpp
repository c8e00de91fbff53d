// census_transform on the device: kernels/census.cl, one program per (kind, window, mean kernel).
#include <stdexcept>
#include <string>

#include "opencl/stages.hpp"

namespace mctstereo::detail::opencl {

namespace {

std::string census_options(const CensusConfig& config) {
  const int window = config.window;
  if (window != 3 && window != 5 && window != 7 && window != 9)
    throw std::invalid_argument("census_transform: window " + std::to_string(window) + " is not 3, 5, 7 or 9");
  std::string options = "-DWINDOW=" + std::to_string(window);
  if (config.kind == CensusKind::Census)
    options += " -DMODIFIED=0";  // the mean kernel plays no part: one program for both
  else
    options += std::string(" -DMODIFIED=1 -DGAUSSIAN=") + (config.kernel == MeanKernel::Gaussian ? "1" : "0");
  return options;
}

}  // namespace

CensusTransform::CensusTransform(Runtime& rt, const CensusConfig& config)
    : StageKernel(rt, "census", "census_transform", census_options(config)), window_(config.window) {}

void CensusTransform::run(const DevicePlane<std::uint8_t>& image, DeviceCodes& codes) {
  if (codes.words != census_words(window_))
    throw std::invalid_argument("census_transform: a " + std::to_string(window_) + " x " + std::to_string(window_) +
                                " window needs " + std::to_string(census_words(window_)) + " code words, not " +
                                std::to_string(codes.words));
  // The kernel writes every word plane with the stride of the first: the caller allocates them
  // alike, each the size of the image.
  for (int k = 0; k < codes.words; ++k) {
    const DevicePlane<std::uint32_t>& plane = codes.plane[k];
    if (plane.width != image.width || plane.height != image.height || plane.stride != codes.plane[0].stride)
      throw std::invalid_argument("census_transform: code plane " + std::to_string(k) + " is " +
                                  std::to_string(plane.width) + " x " + std::to_string(plane.height) +
                                  ", the image " + std::to_string(image.width) + " x " +
                                  std::to_string(image.height));
  }
  if (image.width == 0 || image.height == 0) return;
  // Planes beyond codes.words are never written; the first stands in for them.
  const auto word = [&](int k) -> const cl::Buffer& { return codes.plane[k < codes.words ? k : 0].buffer; };
  set_args(image.buffer, image.width, image.height, image.stride, word(0), word(1), word(2), codes.plane[0].stride);
  enqueue_chunks(image.width, image.height, "census");
}

void census_transform(Runtime& rt, const DevicePlane<std::uint8_t>& image, const CensusConfig& config,
                      DeviceCodes& codes) {
  CensusTransform(rt, config).run(image, codes);
}

}  // namespace mctstereo::detail::opencl
