// Matches a pair of binary PPM or PGM files (P6, P5: the bundled data/tsukuba/imL.ppm, imR.ppm) with
// a preset and writes the disparity map as `match -o MAP.pfm` does (d = Q4 / 16, +inf where there is
// none). It needs nothing but the library, so that a cross-built library (aarch64 under qemu) can
// make the map that CI compares byte for byte with the x86 one.
//
// Usage: mctstereo_match_ppm LEFT RIGHT OUT.pfm [PRESET [NUM_DISPARITIES [THREADS]]]
//   (defaults: balanced, 16, 2)
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/matcher.hpp"
#include "mctstereo/params.hpp"
#include "mctstereo/pfm.hpp"

namespace {

struct Image {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint8_t> pixels;
};

// A binary PPM (P6) or PGM (P5) of 8-bit samples, without comments.
Image read_pnm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  std::string magic;
  int maxval = 0;
  Image image;
  in >> magic >> image.width >> image.height >> maxval;
  if (!in || (magic != "P6" && magic != "P5") || maxval != 255 || image.width <= 0 || image.height <= 0 ||
      image.width > 32768 || image.height > 32768)
    throw std::runtime_error("'" + path + "' is not a binary 8-bit PPM or PGM");
  in.get();  // the one white-space byte before the samples
  image.channels = magic == "P6" ? 3 : 1;
  image.pixels.resize(static_cast<std::size_t>(image.width) * image.height * image.channels);
  in.read(reinterpret_cast<char*>(image.pixels.data()), static_cast<std::streamsize>(image.pixels.size()));
  if (in.gcount() != static_cast<std::streamsize>(image.pixels.size()))
    throw std::runtime_error("'" + path + "' is truncated");
  return image;
}

mctstereo::ImageView view(const Image& image) {
  return {image.pixels.data(), image.width, image.height, static_cast<std::ptrdiff_t>(image.width) * image.channels,
          image.channels == 3 ? mctstereo::PixelFormat::Rgb8 : mctstereo::PixelFormat::Gray8};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4 || argc > 7) {
    std::cerr << "usage: mctstereo_match_ppm LEFT RIGHT OUT.pfm [PRESET [NUM_DISPARITIES [THREADS]]]\n";
    return 2;
  }
  try {
    const Image left = read_pnm(argv[1]), right = read_pnm(argv[2]);
    if (left.width != right.width || left.height != right.height || left.channels != right.channels)
      throw std::runtime_error("the two images differ in size or channels");
    mctstereo::StereoParams params = mctstereo::preset(argc > 4 ? argv[4] : "balanced");
    params.num_disparities = argc > 5 ? std::atoi(argv[5]) : 16;
    mctstereo::MatcherOptions options;
    options.threads = argc > 6 ? std::atoi(argv[6]) : 2;
    mctstereo::Matcher matcher(left.width, left.height, params, mctstereo::Backend::Cpu, options);
    matcher.compute(view(left), view(right));
    const mctstereo::MapView<const std::int16_t> q4 = matcher.disparity_q4();
    std::vector<float> values(static_cast<std::size_t>(q4.width) * q4.height);
    for (int y = 0; y < q4.height; ++y)
      for (int x = 0; x < q4.width; ++x) {
        const std::int16_t v = q4.data[y * q4.stride + x];
        values[static_cast<std::size_t>(y) * q4.width + x] =
            v == matcher.invalid_q4() ? mctstereo::kPfmNone : static_cast<float>(v) / mctstereo::kDisparityScale;
      }
    const std::vector<std::uint8_t> pfm =
        mctstereo::encode_pfm(mctstereo::MapView<const float>{values.data(), q4.width, q4.height, q4.width});
    std::ofstream out(argv[3], std::ios::binary);
    out.write(reinterpret_cast<const char*>(pfm.data()), static_cast<std::streamsize>(pfm.size()));
    out.close();
    if (!out) throw std::runtime_error(std::string("cannot write '") + argv[3] + "'");
    std::cout << argv[3] << ": " << q4.width << "x" << q4.height << ", preset " << (argc > 4 ? argv[4] : "balanced")
              << ", SIMD target " << matcher.simd_target() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "mctstereo_match_ppm: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
