// Depth maps and point clouds as files: the encodings behind match --depth, --ply, --obj and the
// per-frame outputs of stream.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mctstereo/depth.hpp"

namespace mctstereo::app {

/// How a depth map is stored.
enum class DepthFormat {
  Pfm,            ///< 32-bit float in the units of the baseline (or 1/d for relative depth), +INF = none
  PngMillimetres, ///< 16-bit PNG, value = depth in millimetres rounded, 0 = none or beyond 65.535 m
};

/// The format of a depth file from its extension (.pfm or .png); UsageError naming the file otherwise.
DepthFormat depth_format_for(const std::string& path);

/// Factor from `units` ("m", "cm", "mm", "in", "ft"; case-insensitive) to millimetres; UsageError
/// for a unit it does not know, naming it, since a 16-bit PNG holds millimetres.
double millimetres_per_unit(const std::string& units);

/// The bytes of a depth file. `units` is the unit of `depth` ("" for relative depth, which only PFM
/// can hold: UsageError for PNG).
std::vector<std::uint8_t> encode_depth(MapView<const float> depth, const std::string& units, DepthFormat format);

/// How a point cloud is stored.
enum class CloudFormat { Ply, Obj };

/// The bytes of a point cloud file (write_ply / write_obj) with `comments` in its header.
std::vector<std::uint8_t> encode_point_cloud(const PointCloud& cloud, CloudFormat format,
                                             const std::vector<std::string>& comments);

}  // namespace mctstereo::app
