// census_transform on the device: kernels/census.cl, one program per (kind, window, mean kernel).
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

void census_transform(Runtime& rt, const DevicePlane<std::uint8_t>& image, const CensusConfig& config,
                      DeviceCodes& codes) {
  const int window = config.window;
  if (window != 3 && window != 5 && window != 7 && window != 9)
    throw std::invalid_argument("census_transform: window " + std::to_string(window) + " is not 3, 5, 7 or 9");
  if (codes.words != census_words(window))
    throw std::invalid_argument("census_transform: a " + std::to_string(window) + " x " + std::to_string(window) +
                                " window needs " + std::to_string(census_words(window)) + " code words, not " +
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

  std::string options = "-DWINDOW=" + std::to_string(window);
  if (config.kind == CensusKind::Census)
    options += " -DMODIFIED=0";  // the mean kernel plays no part: one program for both
  else
    options += std::string(" -DMODIFIED=1 -DGAUSSIAN=") + (config.kernel == MeanKernel::Gaussian ? "1" : "0");
  cl::Kernel kernel = rt.kernel("census", "census_transform", options);
  kernel.setArg(0, image.buffer);
  kernel.setArg(1, image.width);
  kernel.setArg(2, image.height);
  kernel.setArg(3, image.stride);
  // Planes beyond codes.words are never written; the first stands in for them.
  for (int k = 0; k < 3; ++k) kernel.setArg(4 + k, codes.plane[k < codes.words ? k : 0].buffer);
  kernel.setArg(7, codes.plane[0].stride);
  rt.run(kernel, global_for((image.width + 15) / 16, image.height), kLocal, "census");
}

}  // namespace mctstereo::detail::opencl
