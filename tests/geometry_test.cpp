// The geometry of a rectified pair from OpenCV's P1, P2 and Q and back, and the matrices that give
// none refused by name.
#include <gtest/gtest.h>

#include <string>

#include "mctstereo/depth.hpp"

namespace mctstereo {
namespace {

StereoGeometry example() {
  StereoGeometry g;
  g.focal = 700.5;
  g.cx = 320.25;
  g.cy = 240.75;
  g.baseline = 0.12;
  g.doffs = 3.5;
  g.units = "m";
  return g;
}

void expect_geometry(const StereoGeometry& a, const StereoGeometry& b) {
  EXPECT_DOUBLE_EQ(a.focal, b.focal);
  EXPECT_DOUBLE_EQ(a.cx, b.cx);
  EXPECT_DOUBLE_EQ(a.cy, b.cy);
  EXPECT_DOUBLE_EQ(a.baseline, b.baseline);
  EXPECT_DOUBLE_EQ(a.doffs, b.doffs);
  EXPECT_EQ(a.units, b.units);
}

// The matrix's problem, as "MATRIX: PROBLEM"; empty when it gives a geometry.
template <typename F>
std::string problem_of(F&& f) {
  try {
    f();
  } catch (const GeometryMatrixError& e) {
    return e.matrix() + ": " + e.problem();
  }
  return "";
}

TEST(Geometry, MatricesAreOpenCVs) {
  const StereoGeometry g = example();
  const ProjectionMatrix p1 = left_projection(g), p2 = right_projection(g);
  EXPECT_EQ(p1, (ProjectionMatrix{700.5, 0, 320.25, 0, 0, 700.5, 240.75, 0, 0, 0, 1, 0}));
  EXPECT_EQ(p2, (ProjectionMatrix{700.5, 0, 323.75, -700.5 * 0.12, 0, 700.5, 240.75, 0, 0, 0, 1, 0}));
  const ReprojectionMatrix q = reprojection_matrix(g);
  EXPECT_EQ(q, (ReprojectionMatrix{1, 0, 0, -320.25, 0, 1, 0, -240.75, 0, 0, 0, 700.5, 0, 0, 1 / 0.12, 3.5 / 0.12}));
}

TEST(Geometry, RoundTripsThroughProjectionsAndQ) {
  const StereoGeometry g = example();
  expect_geometry(geometry_from_projections(left_projection(g), right_projection(g)), g);
  expect_geometry(geometry_from_reprojection(reprojection_matrix(g)), g);
  EXPECT_EQ(geometry_from_projections(left_projection(g), right_projection(g), "mm").units, "mm");
}

TEST(Geometry, QReprojectsADisparityToTheDepthOfTheGeometry) {
  // reprojectImageTo3D: [X Y Z W] = Q [x y d 1], point = [X Y Z] / W.
  const StereoGeometry g = example();
  const ReprojectionMatrix q = reprojection_matrix(g);
  const double x = 100, y = 50, d = 20;
  double v[4];
  for (int r = 0; r < 4; ++r) v[r] = q[4 * r] * x + q[4 * r + 1] * y + q[4 * r + 2] * d + q[4 * r + 3];
  EXPECT_NEAR(v[2] / v[3], g.depth(d), 1e-12);
  EXPECT_NEAR(v[0] / v[3], (x - g.cx) * g.depth(d) / g.focal, 1e-12);
}

TEST(Geometry, MatricesWithoutAGeometryAreRefusedByName) {
  const StereoGeometry g = example();
  ProjectionMatrix p1 = left_projection(g), p2 = right_projection(g);
  p1[0] = 0;
  EXPECT_EQ(problem_of([&] { geometry_from_projections(p1, p2); }), "P1: has a focal length P1(0,0) = 0 <= 0");
  p1 = left_projection(g);
  p2[7] = 5;  // P2(1,3): a vertical pair
  EXPECT_EQ(problem_of([&] { geometry_from_projections(p1, p2); }),
            "P2: describes a vertical pair (P2(1,3) != 0): only left-right pairs are matched");
  p2 = right_projection(g);
  p2[3] = -p2[3];  // the cameras swapped
  EXPECT_NE(problem_of([&] { geometry_from_projections(p1, p2); }).find("P2: gives a baseline"), std::string::npos);
  ReprojectionMatrix q = reprojection_matrix(g);
  q[14] = -q[14];
  EXPECT_NE(problem_of([&] { geometry_from_reprojection(q); }).find("Q: gives a baseline 1/Q(3,2)"), std::string::npos);
  q = reprojection_matrix(g);
  q[11] = 0;
  EXPECT_EQ(problem_of([&] { geometry_from_reprojection(q); }), "Q: has a focal length Q(2,3) = 0 <= 0");
}

}  // namespace
}  // namespace mctstereo
