// The geometry of a rectified pair from OpenCV's matrices (P1, P2, Q) and back.
#include <sstream>
#include <string>

#include "mctstereo/depth.hpp"

namespace mctstereo {

namespace {

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Element (row, column) of a row-major matrix of `columns` columns.
template <std::size_t N>
double at(const std::array<double, N>& m, int row, int column, int columns) {
  return m[static_cast<std::size_t>(row * columns + column)];
}

}  // namespace

StereoGeometry geometry_from_projections(const ProjectionMatrix& P1, const ProjectionMatrix& P2,
                                         const std::string& units) {
  StereoGeometry g;
  g.units = units;
  g.focal = at(P1, 0, 0, 4);
  g.cx = at(P1, 0, 2, 4);
  g.cy = at(P1, 1, 2, 4);
  const double right_focal = at(P2, 0, 0, 4);
  if (!(g.focal > 0)) throw GeometryMatrixError("P1", "has a focal length P1(0,0) = " + number_text(g.focal) + " <= 0");
  if (!(right_focal > 0))
    throw GeometryMatrixError("P2", "has a focal length P2(0,0) = " + number_text(right_focal) + " <= 0");
  if (at(P2, 1, 3, 4) != 0.0)
    throw GeometryMatrixError("P2", "describes a vertical pair (P2(1,3) != 0): only left-right pairs are matched");
  g.baseline = -at(P2, 0, 3, 4) / right_focal;
  if (!(g.baseline > 0))
    throw GeometryMatrixError("P2", "gives a baseline -P2(0,3)/P2(0,0) = " + number_text(g.baseline) +
                                        " <= 0 (are the left and right cameras swapped?)");
  g.doffs = at(P2, 0, 2, 4) - g.cx;
  return g;
}

StereoGeometry geometry_from_reprojection(const ReprojectionMatrix& Q, const std::string& units) {
  StereoGeometry g;
  g.units = units;
  g.cx = -at(Q, 0, 3, 4);
  g.cy = -at(Q, 1, 3, 4);
  g.focal = at(Q, 2, 3, 4);
  if (!(g.focal > 0)) throw GeometryMatrixError("Q", "has a focal length Q(2,3) = " + number_text(g.focal) + " <= 0");
  const double inverse_baseline = at(Q, 3, 2, 4);
  if (!(inverse_baseline > 0))
    throw GeometryMatrixError("Q", "gives a baseline 1/Q(3,2) that is not positive (Q(3,2) = " +
                                       number_text(inverse_baseline) + "; are the left and right cameras swapped?)");
  g.baseline = 1.0 / inverse_baseline;
  g.doffs = at(Q, 3, 3, 4) * g.baseline;
  return g;
}

ProjectionMatrix left_projection(const StereoGeometry& g) {
  return {g.focal, 0, g.cx, 0, 0, g.focal, g.cy, 0, 0, 0, 1, 0};
}

ProjectionMatrix right_projection(const StereoGeometry& g) {
  return {g.focal, 0, g.cx + g.doffs, -g.focal * g.baseline, 0, g.focal, g.cy, 0, 0, 0, 1, 0};
}

ReprojectionMatrix reprojection_matrix(const StereoGeometry& g) {
  return {1, 0, 0, -g.cx, 0, 1, 0, -g.cy, 0, 0, 0, g.focal, 0, 0, 1.0 / g.baseline, g.doffs / g.baseline};
}

}  // namespace mctstereo
