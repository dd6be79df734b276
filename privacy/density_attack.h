#pragma once
// The neighbourhood-density attack on line clouds (Chelani, Kahl, Olsson, "How Privacy-Preserving
// are Line Clouds? Recovering Scene Details from 3D Lines", CVPR 2021).
//
// Why it works: the lines of a line cloud pass through the scene's points, which lie on surfaces,
// so lines are densest where they cross surfaces; a line meets the lines of its hidden point's
// neighbours near that point. The attack, per line L_i:
//  1. coarse: the line density (lines per voxel of a LineGrid over the scene box) along L_i; its
//     num_peaks highest local maxima are the candidate places of the hidden point;
//  2. fine: in a window around each candidate, the closest points of L_i to the lines crossing
//     the window's voxels (distance d_j, parameter s_j along L_i), and the peak of the kernel
//     density sum_j exp(-(s - s_j)^2 / 2h^2) exp(-d_j^2 / 2h^2), found by mean shift with a
//     bandwidth h annealed from voxel/2 down to voxel/16: near-intersections with the lines of
//     nearby points dominate at small h;
//  3. refinement (iterations times): the neighbours are re-estimated from the current estimates
//     (points of other lines within h of L_i in each candidate window) and the peak recomputed
//     the same way on those points.
// The estimate is the best-scoring window's peak. Per-line risk = the peak's margin over the
// next candidate, (S_1 - S_2) / S_1 in [0, 1], with S the density score of a window at the
// finest bandwidth: 1 when one place on the line is unambiguously densest.
//
// Cost: O(N * num_peaks * occupancy * 3) closest-point computations plus the grid (4 bytes per
// line-voxel crossing); parallel over lines; deterministic for a given thread count and input.

#include <vector>

#include <Eigen/Geometry>

#include "privacy/attack_result.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct DensityAttackOptions {
  double target_occupancy = 24.0;  // mean lines per voxel of the index (sets the voxel size)
  int num_peaks = 3;               // candidate windows per line
  int iterations = 1;              // refinement rounds from the current estimates
  int num_threads = 0;             // <= 0: all cores
  // Scene box to search; empty: EstimateSceneBox from the lines and server keyframe centres.
  Eigen::AlignedBox3d box;
};

// Runs on the lines of map (any map: published line cloud or a client map). Lines are taken in
// id order; result vectors are aligned with them.
LineAttackResult RunDensityAttack(const slam::Map& map, const DensityAttackOptions& options = {});

// Same on bare lines (ids = positions); camera_centers only help bounding the scene.
LineAttackResult RunDensityAttack(const std::vector<slam::Line3d>& lines,
                                  const std::vector<Eigen::Vector3d>& camera_centers,
                                  const DensityAttackOptions& options = {});

}  // namespace lcv::privacy
