#pragma once
// Bringing a monocular SLAM map into a ground-truth world frame, for audits and benchmarks that
// compare it with ground truth: the concealed-object check (scene.json boxes are in the scene's
// world frame), the mitigation benchmark (`lcv localize` errors without alignment).
//
// The alignment is the Sim(3) (Umeyama) that maps the keyframes' camera centres onto the ground
// truth's at the same timestamps, as evo's --align --correct_scale does for trajectories, refined
// with the keyframes' orientations (centres of a nearly straight path leave the rotation about it
// free: a 2.4 degree roll on the street scene). It is
// a stand-in for what the LC-VSLAM client gets by construction (it tracks in the server's frame):
// use it only where ground truth exists, and say so in the output.
//
// Transforming a map by a similarity world2_from_world1 = (s, R, t): positions x -> s R x + t;
// covariances Sigma -> s^2 R Sigma R^T; line information Omega -> R Omega R^T / s^2; line
// directions d -> R d; camera poses by slam::TransformPose (scale removed from the camera).
// Lines keep their anchor moved by the same map, so a line cloud's anchor rule ("closest point
// to the origin", mapping/line_cloud.h) no longer holds after the transform: align the point map
// and convert it afterwards.
#include <optional>
#include <string>

#include "mapping/io/trajectory.h"
#include "slam/data/map.h"
#include "slam/geometry/sim3.h"

namespace lcv::privacy {

slam::Map TransformMap(const slam::Map& map, const slam::Sim3d& world2_from_world1);

// The ground-truth pose nearest to timestamp t, or null when none is within max_time_difference
// seconds. Ground-truth timestamps increase (mapping/io/trajectory.h): a binary search.
const mapping::StampedPose* NearestGroundTruthPose(const mapping::Trajectory& ground_truth,
                                                   double t, double max_time_difference);

struct GroundTruthAlignment {
  slam::Sim3d gt_from_map;
  int matched = 0;             // keyframes with a ground-truth pose within the time tolerance
  double rmse = 0.0;           // of the aligned keyframe centres, ground-truth units
};

// Sim(3) from the map's client keyframes (Map::keyframes, else its server keyframes) to the
// ground truth, by nearest timestamp within max_time_difference seconds. Empty when fewer than 3
// keyframes match or the centres are degenerate (collinear, one point); *problem says which.
std::optional<GroundTruthAlignment> AlignMapToGroundTruth(const slam::Map& map,
                                                          const mapping::Trajectory& ground_truth,
                                                          double max_time_difference = 0.02,
                                                          std::string* problem = nullptr);

}  // namespace lcv::privacy
