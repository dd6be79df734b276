#pragma once
// Registration of a client map segment into the server's line cloud from the per-keyframe
// line-cloud localizations (p6L, slam/module/line_cloud_localizer.h) of several of its keyframes:
// the fallback of the paper's P4L / P3P relocalization (slam/module/line_cloud_relocalizer.h)
// where that one cannot find enough inliers among the few, young points of a map that has just
// started (after a tracking loss, or at a place where the line cloud ends). p6L matches every
// keypoint of a keyframe to the lines, not only the triangulated ones, and needs no client depth.
//
// Each view is a client keyframe with its client pose (rigid within the segment, client units)
// and its p6L pose and inlier (bearing, line) pairs in the server frame. The similarity
// server_from_client S must map every client pose to its p6L pose
// (TransformPose(S, client) = server):
//
// 1. hypotheses: for each pair of views, the rotation of the first and the scale and translation
//    that put both camera centres on their p6L centres; a view agrees with a hypothesis when its
//    rotation is within max_rotation_deg and its centre within max_centre_of_depth median line
//    distances; the hypothesis with the most agreeing views wins (ties: the smaller summed centre
//    residual);
// 2. the agreeing views' rotations averaged, scale and translation by least squares on their
//    centres;
// 3. refinement: Gauss-Newton with a Huber loss on the bearing-to-plane residual (p6L's error,
//    slam/solve/p6l.h) of every inlier pair of the agreeing views, over the 7 parameters of S,
//    the views rigid in the client frame (their relative poses are the client's: the multi-view
//    geometry, not the p6L centres, determines the scale);
// 4. verification: >= min_views agreeing views spanning >= min_span_of_depth median line
//    distances (a scale from a shorter baseline is too uncertain), each keeping >=
//    min_inlier_ratio of its p6L inliers under max_error_rad, >= min_inliers in all.
//
// Failure is a value (success false, `failure` saying which step stopped); nothing throws.

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/geometry/sim3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct LineCloudViewRegistrationOptions {
  bool enabled = true;
  int min_views = 3;
  int max_views = 8;  // the newest views are kept
  // p6L runs on at most this many keyframes of a segment (one localization costs ~50-100 ms on
  // the mapping thread: a client that never meets the line cloud stops paying for it).
  int max_keyframes_per_segment = 20;
  int min_view_inliers = 20;  // p6L inliers for a keyframe to become a view
  // p6L's RANSAC samples per keyframe: 200 find an all-inlier sample of 6 with 96% probability
  // at an inlier ratio of 0.5; a keyframe with fewer inliers is skipped (measured: a keyframe
  // where p6L fails cost 6.5 s with its default 2000 samples, ~0.5 s with 300).
  int max_ransac_trials = 200;
  double max_rotation_deg = 1.0;
  double max_centre_of_depth = 0.01;
  double min_span_of_depth = 0.15;
  double max_error_rad = 0.0;  // inlier threshold of the refinement (0: the localizer's)
  double min_inlier_ratio = 0.6;
  int min_inliers = 60;
  int max_iterations = 15;
};

struct LineCloudView {
  Id keyframe_id = kInvalidId;
  std::vector<std::pair<int, Id>> matches;  // p6L inliers: (keypoint index, line id)
  Rigid3d client_cam_from_world;  // client frame and units (read from the map when solving)
  Rigid3d server_cam_from_world;  // p6L
  std::vector<Eigen::Vector3d> bearings;  // p6L inliers: unit bearings (camera frame) ...
  std::vector<Line3d> lines;              // ... and their lines (server frame)
};

struct LineCloudViewRegistration {
  bool success = false;
  std::string failure;
  Sim3d server_from_client;
  std::vector<Id> view_keyframe_ids;  // the agreeing views
  int num_inliers = 0;                // bearing-line pairs within max_error_rad after refinement
  double span_of_depth = 0.0;         // spread of the agreeing views' centres / median distance
};

LineCloudViewRegistration RegisterFromViews(const std::vector<LineCloudView>& views,
                                            const LineCloudViewRegistrationOptions& options);

// The bearing-to-plane residual of a view's bearing and server line with the view posed at
// TransformPose(server_from_client, client_cam_from_world), and its 1x7 Jacobian with respect to
// the left perturbation of server_from_client (Sim3d::Exp order [v; omega; sigma]). False when
// the line passes through the camera centre.
bool ViewBearingPlaneResidual(const Sim3d& server_from_client,
                              const Rigid3d& client_cam_from_world,
                              const Eigen::Vector3d& bearing, const Line3d& server_line,
                              double* residual, Eigen::Matrix<double, 1, 7>* jacobian);

}  // namespace lcv::slam
