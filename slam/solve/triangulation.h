#pragma once
// Triangulation of one 3D point from two bearing rays.
//
// Equation: the point X (world frame) is seen along unit bearings x1, x2:
//   depth1 * x1 = R1 X + t1,   depth2 * x2 = R2 X + t2,   cam_i_from_world = (R_i, t_i).
// Method: midpoint of the common perpendicular of the two rays (exact for noise-free rays;
// Hartley & Sturm 1997 discuss its bias, negligible at the parallaxes SLAM keeps).
// Depths are distances along the bearings (metric in map units), so "in front" means positive
// depth for any central camera, including > 180 degree fields of view.

#include <optional>

#include <Eigen/Core>

#include "slam/geometry/rigid3.h"

namespace lcv::slam {

struct TriangulatedPoint {
  Eigen::Vector3d point_in_world = Eigen::Vector3d::Zero();
  double depth1 = 0.0;         // along bearing1, of the triangulated point
  double depth2 = 0.0;         // along bearing2
  double parallax_rad = 0.0;   // angle between the two rays at the point, [0, pi]
};

// Triangulates the bearings (unit, in their camera frames). Empty when the rays are parallel
// (parallax below min_parallax_rad, or the camera centres coincide), or when the point is not
// at positive depth along both rays. Does not check the reprojection error: see
// bearing_error.h.
std::optional<TriangulatedPoint> TriangulateBearings(const Rigid3d& cam1_from_world,
                                                     const Rigid3d& cam2_from_world,
                                                     const Eigen::Vector3d& bearing1,
                                                     const Eigen::Vector3d& bearing2,
                                                     double min_parallax_rad = 0.0);

}  // namespace lcv::slam
