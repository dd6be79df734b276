#include "privacy/map_ground_truth_poses.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <vector>

#include "privacy/map_alignment.h"
#include "slam/camera/camera.h"
#include "slam/feature/scale_pyramid.h"
#include "slam/optimize/bundle_adjustment.h"
#include "slam/util/error.h"

namespace lcv::privacy {
namespace {

// Root mean square pixel error of the problem's inlier observations (projectable ones).
double RmsReprojectionPx(const slam::BundleProblem& problem) {
  double sum = 0.0;
  int count = 0;
  for (const slam::BundleObservation& o : problem.observations) {
    if (o.outlier) continue;
    const slam::BundleKeyframe& kf = problem.keyframes[o.keyframe];
    const auto px = kf.camera->Project(kf.cam_from_world * problem.points[o.landmark].position);
    if (!px) continue;
    sum += (*px - o.observed_px).squaredNorm();
    ++count;
  }
  return count > 0 ? std::sqrt(sum / count) : 0.0;
}

}  // namespace

slam::Map PutMapOnGroundTruthPoses(const slam::Map& aligned_map,
                                   const mapping::Trajectory& ground_truth,
                                   const GroundTruthPosesOptions& options,
                                   const std::string& source_name,
                                   GroundTruthPosesReport* report) {
  if (!aligned_map.lines.empty() || !aligned_map.server_keyframes.empty()) {
    throw InputError(source_name,
                     "has lines or server keyframes: ground-truth poses apply to a point map "
                     "(convert it to lines afterwards)");
  }
  GroundTruthPosesReport local;
  GroundTruthPosesReport& r = report != nullptr ? *report : local;
  r = GroundTruthPosesReport{};

  slam::Map out = aligned_map;
  std::map<slam::Id, std::unique_ptr<slam::Camera>> cameras;
  for (const auto& [id, params] : out.cameras) cameras[id] = slam::MakeCamera(params);

  // The ground-truth pose of each keyframe that has one.
  std::map<slam::Id, slam::Rigid3d> truth;
  for (const auto& [id, kf] : out.keyframes) {
    const mapping::StampedPose* gt =
        NearestGroundTruthPose(ground_truth, kf.timestamp, options.max_time_difference);
    if (gt != nullptr) truth[id] = gt->cam_from_world;
  }
  // The camera's rotation against the ground truth's camera frame: the mean of
  // R_map R_gt^T over the keyframes (quaternions on one hemisphere, summed, normalized; exact
  // for a constant offset, the chordal mean otherwise).
  Eigen::Quaterniond camera_from_gt_camera = Eigen::Quaterniond::Identity();
  if (options.estimate_camera_rotation && !truth.empty()) {
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    for (const auto& [id, gt] : truth) {
      Eigen::Quaterniond q = out.keyframes.at(id).cam_from_world.rotation * gt.rotation.inverse();
      q.normalize();
      if (q.w() < 0) q.coeffs() *= -1.0;
      sum += q.coeffs();
    }
    camera_from_gt_camera.coeffs() = sum.normalized();
    r.camera_rotation_offset_deg =
        camera_from_gt_camera.angularDistance(Eigen::Quaterniond::Identity()) * 180.0 / M_PI;
  }

  slam::BundleProblem problem;
  std::map<slam::Id, int> keyframe_index;
  for (auto& [id, kf] : out.keyframes) {
    const auto gt = truth.find(id);
    if (gt != truth.end()) {
      // Centre from the ground truth, orientation from it and the camera's offset.
      const Eigen::Quaterniond rotation = (camera_from_gt_camera * gt->second.rotation).normalized();
      kf.cam_from_world = slam::Rigid3d(rotation, -(rotation * gt->second.Center()));
      ++r.keyframes_on_ground_truth;
    } else {
      ++r.keyframes_kept;
    }
    slam::BundleKeyframe b;
    b.id = id;
    b.cam_from_world = kf.cam_from_world;
    b.camera = cameras.at(kf.camera_id).get();
    b.fixed = true;
    keyframe_index[id] = static_cast<int>(problem.keyframes.size());
    problem.keyframes.push_back(b);
  }
  if (r.keyframes_on_ground_truth == 0) {
    throw InputError(source_name, "no keyframe has a ground-truth pose within " +
                                      std::to_string(options.max_time_difference) + " s");
  }

  // The pyramid's scale factor is not in the map file: the extractor's default (1.2), as the
  // engine uses for every map it writes.
  const slam::ScalePyramid levels;
  // A point's observations are consecutive in problem.observations, in its own order.
  for (const auto& [id, point] : out.points) {
    const int landmark = static_cast<int>(problem.points.size());
    problem.points.push_back({id, point.position, false});
    for (const slam::Observation& ob : point.observations) {
      const slam::Keyframe& kf = out.keyframes.at(ob.keyframe_id);
      const slam::Keypoint& kp = kf.keypoints.at(ob.keypoint_index);
      slam::BundleObservation o;
      o.keyframe = keyframe_index.at(ob.keyframe_id);
      o.landmark = landmark;
      o.observed_px = Eigen::Vector2d(kp.x, kp.y);
      o.information = levels.InvSigma2(kp.octave);
      problem.observations.push_back(o);
    }
  }
  r.points_in = static_cast<int>(out.points.size());
  r.rms_px_before = RmsReprojectionPx(problem);

  slam::BundleOptions ba;
  ba.max_iterations = options.max_iterations;
  ba.max_refine_iterations = options.max_iterations;
  const slam::BundleReport solved = slam::SolveBundleAdjustment(ba, &problem);
  if (!solved.success) {
    throw InputError(source_name, "bundle adjustment on the ground-truth poses failed: " +
                                      solved.message);
  }
  if (options.refine_poses && problem.keyframes.size() > 2) {
    // The keyframes follow too; the first two (map order = id order, the order SLAM made them)
    // stay on the ground truth and fix the gauge and the scale. Starting at the ground truth the
    // BA settles in the nearest minimum: corrections of the ground truth's own errors, not a
    // new drift (measured: report.max_pose_correction_m).
    for (size_t i = 2; i < problem.keyframes.size(); ++i) problem.keyframes[i].fixed = false;
    const slam::BundleReport full = slam::SolveBundleAdjustment(ba, &problem);
    if (!full.success) {
      throw InputError(source_name, "bundle adjustment of poses and points failed: " +
                                        full.message);
    }
    for (const slam::BundleKeyframe& b : problem.keyframes) {
      slam::Keyframe& kf = out.keyframes.at(b.id);
      const double moved = (b.cam_from_world.Center() - kf.cam_from_world.Center()).norm();
      r.max_pose_correction_m = std::max(r.max_pose_correction_m, moved);
      kf.cam_from_world = b.cam_from_world;
    }
  }

  // Write back: positions, then the observations the BA kept.
  size_t next = 0;
  for (const slam::BundlePoint& p : problem.points) {
    slam::PointLandmark& point = out.points.at(p.id);
    point.position = p.position;
    std::vector<slam::Observation> kept;
    for (const slam::Observation& observation : point.observations) {
      if (problem.observations[next++].outlier) {
        ++r.observations_removed;
      } else {
        kept.push_back(observation);
      }
    }
    point.observations = std::move(kept);
  }
  for (auto it = out.points.begin(); it != out.points.end();) {
    it = it->second.observations.size() < 2 ? out.points.erase(it) : std::next(it);
  }
  r.points_out = static_cast<int>(out.points.size());
  r.rms_px_after = RmsReprojectionPx(problem);
  return out;
}

}  // namespace lcv::privacy
