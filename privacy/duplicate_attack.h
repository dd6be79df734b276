#pragma once
// The duplicate-line attack: two lines of a line cloud that intersect reveal their common point
// if both stand for the same 3D point (a point published twice, e.g. by two merged maps, or a
// point and its restored X' converted separately). Random lines through distinct points never
// intersect exactly, so a pair that intersects to numerical precision AND shares evidence of
// being one point gives that point away:
// - both lines carry descriptors: Hamming distance <= max_hamming;
// - otherwise (maps imported from COLMAP carry no ORB descriptors): at least
//   min_shared_keyframes server keyframes see both.
// Candidates come from a LineGrid (lines crossing the same voxel, closest point inside it), not
// from all pairs. Why the tolerance is tiny: a line passes within delta of another random line
// of the scene (extent E) with probability ~3 delta / E, so N lines hold ~1.5 N^2 delta / E
// chance pairs: 1500 for N = 1e6 at delta = 1e-9 E, 0.15 at the default 1e-13 E. A true
// duplicate meets to rounding error (~1e-15 |X|; the map files store doubles exactly). Shared
// keyframes are weak evidence (neighbouring points share them), so the geometric test must
// carry the decision when there are no descriptors.
//
// Result: estimate = the midpoint of the closest points, risk 1, for both lines of each pair.

#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "privacy/attack_result.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct DuplicateAttackOptions {
  double relative_tolerance = 1e-13;  // of the scene box diagonal
  int max_hamming = 50;
  int min_shared_keyframes = 1;
  double target_occupancy = 6.0;
  int num_threads = 0;
  Eigen::AlignedBox3d box;  // empty: EstimateSceneBox
};

struct DuplicatePair {
  slam::Id line_a = 0, line_b = 0;  // line_a < line_b
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // where they meet
  double distance = 0.0;                            // between the lines
  int hamming = -1;                                 // -1 when decided by visibility
  int shared_keyframes = 0;
};

LineAttackResult RunDuplicateAttack(const slam::Map& map, const DuplicateAttackOptions& options,
                                    std::vector<DuplicatePair>* pairs);

}  // namespace lcv::privacy
