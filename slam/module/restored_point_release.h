#pragma once
// Releases restored points X' that have moved off their lines (the client side of a wrong
// 2D point - 3D line association).
//
// Tracking matches a keypoint to a line when the keypoint lies in the line's corridor (the
// projection of the stretch where its hidden point can be) with a similar descriptor. In
// repeated texture a keypoint of another physical point P passes those tests when the hidden
// point's own keypoint is missing from the frame, and local mapping restores X' on the line
// from it. The next frames track X' by projection and find P again; local BA, in which lines
// are free (LineCloudSettings::local_ba_frees_line_cloud), then moves X' onto P and drags the
// line along with it, against the virtual observations of the server keyframes. Measured on a
// line cloud without error (the paper's prebuilt map, fisheye `overlap` seed 1): 85 of 252 X'
// ended more than 0.5 m from their hidden points, 95% of them on viewing rays that miss the
// hidden point by more than 0.1 m (docs/slam.md "Wrong line associations").
//
// The test: an X' seen by at least two keyframes that lies more than max_angle_rad, seen from
// `viewpoint` (the new keyframe's centre), from its line's reference position
// (SlamLine::reference_line: as loaded, and as the last global BA left it) is released: it
// stays in the map as an ordinary point X with its observations (it is a real point, P), and
// its line goes back to the reference position, free for a new X'.
#include <vector>

#include "slam/data/slam_map.h"

namespace lcv::slam {

// Returns the number of X' released among `landmark_ids` (ids that are not X' are skipped).
int ReleaseRestoredPointsOffTheirLines(const std::vector<Id>& landmark_ids,
                                       const Eigen::Vector3d& viewpoint, double max_angle_rad,
                                       SlamMap* map);

}  // namespace lcv::slam
