#include "depth_files.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "errors.hpp"
#include "io.hpp"
#include "output_files.hpp"

namespace mctstereo::app {

namespace {

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return std::tolower(c); });
  return text;
}

}  // namespace

DepthFormat depth_format_for(const std::string& path) {
  const std::string ext = lower(std::filesystem::path(path).extension().string());
  if (ext == ".pfm") return DepthFormat::Pfm;
  if (ext == ".png") return DepthFormat::PngMillimetres;
  throw UsageError("cannot tell the depth format of " + in_quotes(path) +
                   ": name it .pfm (float, units of the baseline) or .png (16-bit, millimetres)");
}

double millimetres_per_unit(const std::string& units) {
  const std::string u = lower(units);
  if (u == "mm") return 1.0;
  if (u == "cm") return 10.0;
  if (u == "m") return 1000.0;
  if (u == "in") return 25.4;
  if (u == "ft") return 304.8;
  throw UsageError("unknown unit '" + units + "' (known: m, cm, mm, in, ft)");
}

std::vector<std::uint8_t> encode_depth(MapView<const float> depth, const std::string& units, DepthFormat format) {
  if (format == DepthFormat::Pfm) return encode_pfm(depth);
  if (units.empty())
    throw UsageError("a 16-bit PNG depth map holds millimetres, so it needs a calibration; relative depth 1/d "
                     "goes to a .pfm file");
  const double scale = millimetres_per_unit(units);
  cv::Mat png(depth.height, depth.width, CV_16UC1);
  for (int y = 0; y < depth.height; ++y) {
    const float* src = depth.row(y);
    std::uint16_t* dst = png.ptr<std::uint16_t>(y);
    for (int x = 0; x < depth.width; ++x) {
      const double mm = std::round(src[x] * scale);
      // 0 means "no depth", so a depth beyond 65.535 m becomes none rather than a wrong 65535, and
      // a positive depth under half a millimetre is written as 1 rather than as none.
      dst[x] = !(mm <= 65535.0) || !(src[x] > 0.0f) ? 0 : static_cast<std::uint16_t>(std::max(mm, 1.0));
    }
  }
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", png, bytes)) throw RuntimeError("cannot encode a 16-bit PNG");
  return bytes;
}

std::vector<std::uint8_t> encode_point_cloud(const PointCloud& cloud, CloudFormat format,
                                             const std::vector<std::string>& comments) {
  std::ostringstream out(std::ios::binary);
  if (format == CloudFormat::Ply)
    write_ply(out, cloud, comments);
  else
    write_obj(out, cloud, comments);
  const std::string text = std::move(out).str();
  return {text.begin(), text.end()};
}

}  // namespace mctstereo::app
