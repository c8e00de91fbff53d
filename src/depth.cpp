#include "mctstereo/depth.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <ostream>
#include <stdexcept>

#include "mctstereo/matcher.hpp"

namespace mctstereo {

namespace {

void require_finite(double value, const char* field) {
  if (!std::isfinite(value))
    throw std::invalid_argument(std::string("stereo geometry: ") + field + " must be a finite number (is " +
                                std::to_string(value) + ")");
}

void require_positive(double value, const char* field) {
  if (!(std::isfinite(value) && value > 0.0))
    throw std::invalid_argument(std::string("stereo geometry: ") + field + " must be a positive number (is " +
                                std::to_string(value) + ")");
}

std::string size_text(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

template <typename T, typename U>
void require_same_size(const MapView<T>& a, const MapView<U>& b, const char* what) {
  if (a.width != b.width || a.height != b.height)
    throw std::invalid_argument(std::string(what) + " is " + size_text(b.width, b.height) +
                                " but the disparity map is " + size_text(a.width, a.height));
}

void check_max_depth(double max_depth) {
  // +inf (no cut) is allowed; NaN would silently drop every point.
  if (std::isnan(max_depth) || max_depth <= 0.0)
    throw std::invalid_argument("max_depth must be a positive depth (is " + std::to_string(max_depth) + ")");
}

// Z = f B / (d + doffs) as float, or NaN when there is none: d + doffs <= 0 (at infinity or behind
// the camera) or beyond max_depth. The division is made in double so that the float depth is the
// correctly rounded value of the formula.
inline float depth_of(double disparity, double focal_baseline, double doffs, double max_depth) {
  const double denominator = disparity + doffs;
  if (!(denominator > 0.0)) return kNoDepth;
  const double z = focal_baseline / denominator;
  return z <= max_depth ? static_cast<float>(z) : kNoDepth;
}

// Bytes of a float, little-endian whatever the host.
void append_le(std::string& bytes, float value) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, 4);
  for (int b = 0; b < 4; ++b) bytes.push_back(static_cast<char>(bits >> (8 * b)));
}

void write_comments(std::ostream& out, const char* prefix, const std::vector<std::string>& comments) {
  for (const std::string& comment : comments) {
    std::string line = comment;
    for (char& c : line)
      if (c == '\n' || c == '\r') c = ' ';
    out << prefix << line << '\n';
  }
}

void check_stream(const std::ostream& out, const char* what) {
  if (!out) throw std::runtime_error(std::string("cannot write the ") + what + " point cloud: stream failed");
}

}  // namespace

void StereoGeometry::validate() const {
  require_positive(focal, "focal");
  require_positive(baseline, "baseline");
  require_finite(cx, "cx");
  require_finite(cy, "cy");
  require_finite(doffs, "doffs");
}

StereoGeometry StereoGeometry::scaled(double factor) const {
  if (!(std::isfinite(factor) && factor > 0.0))
    throw std::invalid_argument("stereo geometry: scale factor must be a positive number (is " +
                                std::to_string(factor) + ")");
  StereoGeometry g = *this;
  g.focal = focal * factor;
  g.cx = (cx + 0.5) * factor - 0.5;
  g.cy = (cy + 0.5) * factor - 0.5;
  // doffs is a difference of two principal points: the half-pixel shifts cancel.
  g.doffs = doffs * factor;
  return g;
}

double StereoGeometry::depth(double disparity) const {
  const double denominator = disparity + doffs;
  if (!(denominator > 0.0)) return std::numeric_limits<double>::infinity();
  return focal * baseline / denominator;
}

void depth_from_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4, const StereoGeometry& geometry,
                          MapView<float> depth, double max_depth) {
  geometry.validate();
  check_max_depth(max_depth);
  require_same_size(q4, depth, "the depth map");
  const double fb = geometry.focal * geometry.baseline;
  for (int y = 0; y < q4.height; ++y) {
    const std::int16_t* src = q4.row(y);
    float* dst = depth.row(y);
    for (int x = 0; x < q4.width; ++x)
      dst[x] = src[x] == invalid_q4 ? kNoDepth
                                    : depth_of(src[x] / double(kDisparityScale), fb, geometry.doffs, max_depth);
  }
}

void depth_from_disparity(MapView<const float> disparity, const StereoGeometry& geometry, MapView<float> depth,
                          double max_depth) {
  geometry.validate();
  check_max_depth(max_depth);
  require_same_size(disparity, depth, "the depth map");
  const double fb = geometry.focal * geometry.baseline;
  for (int y = 0; y < disparity.height; ++y) {
    const float* src = disparity.row(y);
    float* dst = depth.row(y);
    for (int x = 0; x < disparity.width; ++x)
      dst[x] = std::isfinite(src[x]) ? depth_of(src[x], fb, geometry.doffs, max_depth) : kNoDepth;
  }
}

void relative_depth_from_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4, MapView<float> depth) {
  require_same_size(q4, depth, "the depth map");
  for (int y = 0; y < q4.height; ++y) {
    const std::int16_t* src = q4.row(y);
    float* dst = depth.row(y);
    for (int x = 0; x < q4.width; ++x)
      dst[x] = src[x] == invalid_q4 || src[x] <= 0 ? kNoDepth : static_cast<float>(double(kDisparityScale) / src[x]);
  }
}

void PointCloud::clear() {
  xyz.clear();
  rgb.clear();
  pixel.clear();
}

void point_cloud_from_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4,
                                const StereoGeometry& geometry, const ImageView& colours, PointCloud& cloud,
                                double max_depth) {
  geometry.validate();
  check_max_depth(max_depth);
  const bool with_colours = colours.data != nullptr;
  if (with_colours && (colours.width != q4.width || colours.height != q4.height))
    throw std::invalid_argument("the colour image is " + size_text(colours.width, colours.height) +
                                " but the disparity map is " + size_text(q4.width, q4.height));
  cloud.clear();
  cloud.units = geometry.units;  // short units fit the string's own storage: no allocation
  const double fb = geometry.focal * geometry.baseline;
  const double inverse_focal = 1.0 / geometry.focal;
  const int channels = with_colours ? bytes_per_pixel(colours.format) : 0;
  // Where R, G and B sit in a pixel of the colour image.
  const int r_at = with_colours && colours.format == PixelFormat::Bgr8 ? 2 : 0;
  const int g_at = channels == 3 ? 1 : 0;
  const int b_at = with_colours && colours.format == PixelFormat::Rgb8 ? 2 : 0;
  for (int y = 0; y < q4.height; ++y) {
    const std::int16_t* src = q4.row(y);
    const std::uint8_t* colour_row = with_colours ? colours.row(y) : nullptr;
    const double y_over_f = (y - geometry.cy) * inverse_focal;
    for (int x = 0; x < q4.width; ++x) {
      if (src[x] == invalid_q4) continue;
      // As depth_of, keeping Z in double for X and Y.
      const double denominator = src[x] / double(kDisparityScale) + geometry.doffs;
      if (!(denominator > 0.0)) continue;
      const double z = fb / denominator;
      if (!(z <= max_depth)) continue;
      cloud.xyz.push_back(static_cast<float>((x - geometry.cx) * inverse_focal * z));
      cloud.xyz.push_back(static_cast<float>(y_over_f * z));
      cloud.xyz.push_back(static_cast<float>(z));
      cloud.pixel.push_back(y * q4.width + x);
      if (with_colours) {
        const std::uint8_t* p = colour_row + x * channels;
        cloud.rgb.push_back(p[r_at]);
        cloud.rgb.push_back(p[g_at]);
        cloud.rgb.push_back(p[b_at]);
      }
    }
  }
}

void write_ply(std::ostream& out, const PointCloud& cloud, const std::vector<std::string>& comments) {
  out << "ply\nformat binary_little_endian 1.0\n";
  write_comments(out, "comment ", comments);
  out << "element vertex " << cloud.size() << "\n"
      << "property float x\nproperty float y\nproperty float z\n";
  if (cloud.has_colours()) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out << "end_header\n";
  // Written in blocks of points: one stream call per point would dominate for large clouds.
  constexpr std::size_t kBlock = 4096;
  std::string bytes;
  bytes.reserve(kBlock * 15);
  for (std::size_t begin = 0; begin < cloud.size(); begin += kBlock) {
    bytes.clear();
    const std::size_t end = std::min(cloud.size(), begin + kBlock);
    for (std::size_t i = begin; i < end; ++i) {
      for (int k = 0; k < 3; ++k) append_le(bytes, cloud.xyz[3 * i + k]);
      if (cloud.has_colours())
        for (int k = 0; k < 3; ++k) bytes.push_back(static_cast<char>(cloud.rgb[3 * i + k]));
    }
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  out.flush();
  check_stream(out, "PLY");
}

void write_obj(std::ostream& out, const PointCloud& cloud, const std::vector<std::string>& comments) {
  write_comments(out, "# ", comments);
  // %.9g writes every float so that it reads back to the same float.
  char line[160];
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const float* p = &cloud.xyz[3 * i];
    int n = std::snprintf(line, sizeof line, "v %.9g %.9g %.9g", p[0], p[1], p[2]);
    if (cloud.has_colours()) {
      const std::uint8_t* c = &cloud.rgb[3 * i];
      n += std::snprintf(line + n, sizeof line - n, " %.6g %.6g %.6g", c[0] / 255.0, c[1] / 255.0, c[2] / 255.0);
    }
    line[n++] = '\n';
    out.write(line, n);
  }
  out.flush();
  check_stream(out, "OBJ");
}

}  // namespace mctstereo
