// mctstereo: from disparity to depth and point clouds, and the files that hold point clouds.
//
// Conventions (docs/PIPELINE.md): a left pixel (x, y) with disparity d lies at depth
//   Z = focal * baseline / (d + doffs),  X = (x - cx) * Z / focal,  Y = (y - cy) * Z / focal
// in the frame of the left rectified camera (X right, Y down, Z forward), in the units of the
// baseline. Pixel centres have integer coordinates, as in OpenCV and Middlebury's calib.txt.
#pragma once

#include <array>
#include <cstdint>
#include <iosfwd>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "mctstereo/image.hpp"

namespace mctstereo {

/// The geometry of a rectified stereo pair, in pixels of the images that were matched.
struct StereoGeometry {
  double focal = 0.0;     ///< focal length, pixels (> 0)
  double cx = 0.0;        ///< principal point of the left rectified camera, pixels
  double cy = 0.0;
  double baseline = 0.0;  ///< distance between the two optical centres, in `units` (> 0)
  double doffs = 0.0;     ///< x difference of the principal points, right minus left, pixels
  std::string units = "m";  ///< unit of the baseline, and so of depth and of X, Y, Z

  /// Throws std::invalid_argument naming the field when focal or baseline is not a positive finite
  /// number, or cx, cy or doffs is not finite.
  void validate() const;
  /// The geometry of the same cameras with images scaled by `factor` (focal, cx, cy and doffs
  /// scale; the baseline does not). Pixel centres stay at integer coordinates:
  /// c' = (c + 0.5) * factor - 0.5.
  StereoGeometry scaled(double factor) const;
  /// Depth of a disparity, in `units`: focal * baseline / (d + doffs); +inf when d + doffs <= 0.
  double depth(double disparity) const;
};

/// A 3 x 4 projection matrix, row-major: OpenCV's P1 and P2 of a rectified pair (stereoRectify).
using ProjectionMatrix = std::array<double, 12>;
/// OpenCV's 4 x 4 reprojection matrix Q (stereoRectify, reprojectImageTo3D), row-major.
using ReprojectionMatrix = std::array<double, 16>;

/// A matrix that gives no geometry of a left-right rectified pair: which one ("P1", "P2" or "Q")
/// and what is wrong with it ("has a focal length P1(0,0) = 0 <= 0"); what() is both.
class GeometryMatrixError : public std::invalid_argument {
 public:
  GeometryMatrixError(const std::string& matrix, const std::string& problem)
      : std::invalid_argument(matrix + " " + problem), matrix_(matrix), problem_(problem) {}
  const std::string& matrix() const { return matrix_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string matrix_, problem_;
};

/// The geometry of a horizontal rectified pair from its projections
/// P1 = [f 0 cx 0; 0 f cy 0; 0 0 1 0], P2 = [f 0 cx2 -f B; 0 f cy 0; 0 0 1 0]:
/// focal = P1(0,0), cx = P1(0,2), cy = P1(1,2), baseline = -P2(0,3) / P2(0,0) in the unit of the
/// calibration's translation (`units`), doffs = P2(0,2) - P1(0,2). GeometryMatrixError for a focal
/// length <= 0, a vertical pair (P2(1,3) != 0) or a baseline <= 0 (swapped cameras).
StereoGeometry geometry_from_projections(const ProjectionMatrix& P1, const ProjectionMatrix& P2,
                                         const std::string& units = "m");
/// The same from Q = [1 0 0 -cx; 0 1 0 -cy; 0 0 0 f; 0 0 1/B doffs/B]: GeometryMatrixError for
/// Q(2,3) <= 0 or Q(3,2) <= 0.
StereoGeometry geometry_from_reprojection(const ReprojectionMatrix& Q, const std::string& units = "m");
/// P1 of a geometry: [f 0 cx 0; 0 f cy 0; 0 0 1 0].
ProjectionMatrix left_projection(const StereoGeometry& geometry);
/// P2 of a geometry: [f 0 cx + doffs -f B; 0 f cy 0; 0 0 1 0].
ProjectionMatrix right_projection(const StereoGeometry& geometry);
/// Q of a geometry: [1 0 0 -cx; 0 1 0 -cy; 0 0 0 f; 0 0 1/B doffs/B]; reprojectImageTo3D of a
/// disparity d at (x, y) gives the point depth_from_disparity and point_cloud_from_disparity give.
ReprojectionMatrix reprojection_matrix(const StereoGeometry& geometry);

/// What a depth map holds where no depth is known: NaN (as the float disparity map).
inline constexpr float kNoDepth = std::numeric_limits<float>::quiet_NaN();

/// Depth of every pixel of a Q4 disparity map (16 x d, `invalid_q4` where invalid), in the units of
/// the baseline. kNoDepth where the disparity is invalid, where d + doffs <= 0 (a point at infinity
/// or behind the camera) and where the depth exceeds `max_depth`. `depth` must have the map's size.
/// std::invalid_argument for another size, an invalid geometry or a max_depth that is not positive.
/// Allocates nothing.
void depth_from_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4, const StereoGeometry& geometry,
                          MapView<float> depth, double max_depth = std::numeric_limits<double>::infinity());

/// The same from a float disparity map in pixels (NaN or +/-inf where invalid).
void depth_from_disparity(MapView<const float> disparity, const StereoGeometry& geometry, MapView<float> depth,
                          double max_depth = std::numeric_limits<double>::infinity());

/// Relative depth 1 / d, for a pair without calibration (the thesis's eq. 4.3.4): proportional to
/// the true depth when doffs = 0. kNoDepth where the disparity is invalid or d <= 0.
void relative_depth_from_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4, MapView<float> depth);

/// A point cloud: one entry per valid pixel, in row-major pixel order.
struct PointCloud {
  std::vector<float> xyz;           ///< X, Y, Z of each point, in `units`
  std::vector<std::uint8_t> rgb;    ///< R, G, B of each point; empty for a cloud without colours
  std::vector<std::int32_t> pixel;  ///< y * width + x of the left pixel of each point (empty: read from a file)
  std::string units = "m";          ///< the geometry's units (point_cloud_from_disparity sets it; "" from read_ply)

  std::size_t size() const { return xyz.size() / 3; }
  bool has_colours() const { return !rgb.empty(); }
  /// Keeps the storage: a cloud reused frame after frame allocates only while it grows.
  void clear();
};

/// Back-projects every valid pixel of a Q4 disparity map that has a depth (as depth_from_disparity,
/// with `max_depth`) into `cloud`, replacing what it held. `colours` is the left image the map was
/// computed from (Gray8, Rgb8 or Bgr8, the map's size), or a view with null data for a cloud without
/// colours. std::invalid_argument when sizes differ, the geometry is invalid or max_depth is not
/// positive. Allocates only while the cloud grows beyond what it held before.
void point_cloud_from_disparity(MapView<const std::int16_t> q4, std::int16_t invalid_q4,
                                const StereoGeometry& geometry, const ImageView& colours, PointCloud& cloud,
                                double max_depth = std::numeric_limits<double>::infinity());

/// Writes `cloud` as binary little-endian PLY: "element vertex N" with float x y z and, when the
/// cloud has colours, uchar red green blue; each of `comments` becomes a "comment" line (newlines
/// are replaced by spaces). Throws std::runtime_error when the stream fails.
void write_ply(std::ostream& out, const PointCloud& cloud, const std::vector<std::string>& comments = {});

/// Reads a PLY point cloud, ascii or binary_little_endian: the vertex element's x y z (any numeric
/// type; values beyond float's range become NaN) and red green blue when it has all three (integers
/// as 0..255, clamped; floats as 0..1); other properties and elements are read past. The cloud has
/// no `pixel` entries and empty `units`. std::runtime_error naming `name` ("point cloud 'a.ply'",
/// say) and what is wrong: not a PLY, another format, a malformed header, no vertices or no x, y or
/// z, a value that is not a number, or a truncated body.
PointCloud read_ply(std::istream& in, const std::string& name = "the PLY data");

/// Writes `cloud` as Wavefront OBJ, one "v x y z" line per point ("v x y z r g b" with colours in
/// [0, 1] when the cloud has them), `comments` as "#" lines. Throws std::runtime_error on failure.
void write_obj(std::ostream& out, const PointCloud& cloud, const std::vector<std::string>& comments = {});

}  // namespace mctstereo
