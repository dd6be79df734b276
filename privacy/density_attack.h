#pragma once
// The neighbourhood-density attack on line clouds (Chelani, Kahl, Olsson, "How Privacy-Preserving
// are Line Clouds? Recovering Scene Details from 3D Lines", CVPR 2021).
//
// Why it works: the lines of a line cloud pass through the scene's points, which lie on surfaces,
// so lines are densest where they cross surfaces; a line meets the lines of its hidden point's
// neighbours near that point. The attack, per line L_i:
//  1. coarse: the line density (lines per voxel of a LineGrid over the scene box, smoothed
//     along the line) along L_i; its num_peaks highest local maxima are the candidate places of
//     the hidden point (the surfaces L_i crosses);
//  2. fine: in a window of +-1.5 voxels around each candidate, the closest points of L_i to the
//     lines crossing the window's voxels (distance d_j, parameter s_j along L_i), and the mode of
//     their kernel density, weight k((s - s_j)^2 + d_j^2) with a biweight kernel k of radius 3h,
//     found by mean shift with h annealed from voxel/2 down to voxel/16: near-intersections with
//     the lines of nearby points dominate at small h;
//  3. optional refinement (`iterations` rounds, default 0): the neighbours are re-estimated from
//     the current estimates (lines whose estimate lies within voxel/2 of L_i in the window) and
//     the mode recomputed from the closest points to those lines only.
// The estimate is the mode of the candidate with the highest coarse density. Chosen by
// measurement on the synthetic street (docs/audit.md): ranking the candidates by their fine
// score, or refining, recovered fewer points. Per-line risk = the winner's margin over the next
// candidate, (C_1 - C_2) / C_1 in [0, 1] with C the smoothed coarse density: 1 when the line
// crosses one dense place only.
//
// Cost: O(N * num_peaks * occupancy * 3) closest-point computations plus the grid (4 bytes per
// line-voxel crossing); parallel over lines; deterministic for a given thread count and input.

#include <vector>

#include <Eigen/Geometry>

#include "privacy/attack_result.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct DensityAttackOptions {
  double target_occupancy = 6.0;  // mean lines per voxel of the index (sets the voxel size)
  int num_peaks = 3;               // candidate windows per line
  int iterations = 0;              // refinement rounds from the current estimates (see docs)
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
