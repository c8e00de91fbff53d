// Matches a rectified pair with the mctstereo library alone (no OpenCV): reads two binary PGM or
// PPM files (data/tsukuba/imL.ppm and imR.ppm are the bundled pair), prints the share of pixels
// with a disparity and their median.
//   consumer LEFT.ppm RIGHT.ppm [NUM_DISPARITIES] [PRESET]
#include <mctstereo/mctstereo.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint8_t> pixels;

  mctstereo::ImageView view() const {
    return {pixels.data(), width, height, static_cast<std::ptrdiff_t>(width) * channels,
            channels == 1 ? mctstereo::PixelFormat::Gray8 : mctstereo::PixelFormat::Rgb8};
  }
};

// Binary PGM (P5) or PPM (P6) with 8-bit samples.
Image read_pnm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string magic;
  in >> magic;
  if (magic != "P5" && magic != "P6") throw std::runtime_error(path + ": not a binary PGM or PPM");
  int fields[3];
  for (int& f : fields) {
    while (in >> std::ws && in.peek() == '#') in.ignore(1 << 20, '\n');
    in >> f;
  }
  in.get();  // the single whitespace before the samples
  Image image{fields[0], fields[1], magic == "P6" ? 3 : 1, {}};
  if (!in || fields[2] != 255 || image.width <= 0 || image.height <= 0)
    throw std::runtime_error(path + ": expected 8-bit samples (maxval 255)");
  image.pixels.resize(static_cast<std::size_t>(image.width) * image.height * image.channels);
  in.read(reinterpret_cast<char*>(image.pixels.data()), static_cast<std::streamsize>(image.pixels.size()));
  if (!in) throw std::runtime_error(path + ": truncated");
  return image;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s LEFT.ppm RIGHT.ppm [NUM_DISPARITIES] [PRESET]\n", argv[0]);
    return 2;
  }
  try {
    const Image left = read_pnm(argv[1]), right = read_pnm(argv[2]);
    mctstereo::StereoParams params = mctstereo::preset(argc > 4 ? argv[4] : "balanced");
    params.num_disparities = argc > 3 ? std::stoi(argv[3]) : 16;

    mctstereo::Matcher matcher(left.width, left.height, params);
    matcher.compute(left.view(), right.view());
    const mctstereo::MapView<const float> disparity = matcher.disparity();  // NaN where invalid

    std::vector<float> valid;
    for (int y = 0; y < disparity.height; ++y)
      for (int x = 0; x < disparity.width; ++x)
        if (!std::isnan(disparity.at(x, y))) valid.push_back(disparity.at(x, y));
    const double fraction = static_cast<double>(valid.size()) / (static_cast<double>(left.width) * left.height);
    float median = NAN;
    if (!valid.empty()) {
      std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
      median = valid[valid.size() / 2];
    }
    std::printf("mctstereo %s (headers %s), %s backend, %s\n", std::string(mctstereo::version()).c_str(),
                MCTSTEREO_VERSION_STRING, std::string(mctstereo::to_string(matcher.backend())).c_str(),
                matcher.simd_target().c_str());
    std::printf("%d x %d, disparities %d..%d: valid %.2f %%, median disparity %.4g px, frame %.2f ms\n",
                left.width, left.height, params.min_disparity, params.max_disparity(), 100.0 * fraction, median,
                matcher.timings().back().ms);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
}
