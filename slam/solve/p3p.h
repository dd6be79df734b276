#pragma once
// Perspective-three-point on bearings: the camera pose from 3 bearing/point pairs.
//
// Equation: lambda_i * x_i = R X_i + t, i = 0..2, with x_i unit bearings in the camera frame,
// X_i points in the world frame, lambda_i > 0 the depths along the bearings, and
// cam_from_world = (R, t).
//
// Method: Lambda Twist (Persson & Nordberg, "Lambda Twist: An Accurate Fast Robust
// Perspective Three Point (P3P) Solver", ECCV 2018): the three distance constraints
//   |lambda_i x_i - lambda_j x_j|^2 = |X_i - X_j|^2
// are combined into a degenerate conic (a cubic in one unknown), which factors into two planes
// in lambda-space; each plane meets a remaining conic in up to two points; each solution is
// polished by a few Gauss-Newton steps on the three constraints. Up to 4 poses.
//
// Degenerate: collinear world points, coincident points or bearings (returns 0 or fewer
// solutions, never NaN). Works for any central camera (bearings may point anywhere).

#include <vector>

#include <Eigen/Core>

#include "slam/geometry/rigid3.h"

namespace lcv::slam {

// Writes the poses (cleared first) and returns their count (0..4). bearings: 3 unit vectors;
// points_in_world: 3 points.
int SolveP3P(const Eigen::Vector3d* bearings, const Eigen::Vector3d* points_in_world,
             std::vector<Rigid3d>* cam_from_world);

}  // namespace lcv::slam
