// Input images as the program reads them (app::read_input_image for the pairs, app::read_gray_image
// for ground truth and masks): the header's declared size is checked before OpenCV decodes, then
// any format OpenCV knows is decoded. Every input must give an 8-bit image of gray or BGR (gray
// only for read_gray_image), or the program's RuntimeError. OpenCV's decoders themselves are not
// instrumented; a crash or an exception of theirs still shows.
//
// Memory: an image within the program's limit of 32768 x 32768 pixels may take gigabytes, more than
// the fuzzer's 2 GiB; scripts/run-fuzzers.sh caps what OpenCV decodes with
// OPENCV_IO_MAX_IMAGE_PIXELS (OpenCV reads it once, when its library loads).
#include <opencv2/core.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "errors.hpp"
#include "fuzz_files.hpp"
#include "io.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (std::getenv("OPENCV_IO_MAX_IMAGE_PIXELS") == nullptr)
    std::fprintf(stderr, "fuzz_image: OPENCV_IO_MAX_IMAGE_PIXELS is not set: large declared sizes may exceed "
                         "the fuzzer's memory limit (scripts/run-fuzzers.sh sets it)\n");
  cv::setNumThreads(1);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mctstereo;
  const std::filesystem::path path = fuzz::scratch_folder() / "image";
  fuzz::write_file(path, data, size);
  try {
    const cv::Mat image = app::read_input_image(path.string(), "left image");
    if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) std::abort();
    const ImageView view = app::image_view(image);
    if (view.width != image.cols || view.height != image.rows || view.stride < view.width * image.channels())
      std::abort();
  } catch (const app::RuntimeError&) {
  }
  try {
    const cv::Mat gray = app::read_gray_image(path.string(), "mask");
    if (gray.empty() || gray.type() != CV_8UC1) std::abort();
  } catch (const app::RuntimeError&) {
  }
  return 0;
}
