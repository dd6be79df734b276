#include "privacy/map_alignment.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "slam/solve/umeyama.h"

namespace lcv::privacy {

slam::Map TransformMap(const slam::Map& map, const slam::Sim3d& world2_from_world1) {
  const slam::Sim3d& S = world2_from_world1;
  const Eigen::Matrix3d R = S.rotation.toRotationMatrix();
  const double s2 = S.scale * S.scale;
  slam::Map out = map;
  for (auto& [id, kf] : out.keyframes) kf.cam_from_world = slam::TransformPose(S, kf.cam_from_world);
  for (auto& [id, kf] : out.server_keyframes) {
    kf.cam_from_world = slam::TransformPose(S, kf.cam_from_world);
  }
  for (auto& [id, p] : out.points) {
    p.position = S * p.position;
    p.covariance = s2 * R * p.covariance * R.transpose();
  }
  for (auto& [id, l] : out.lines) {
    l.line.anchor = S * l.line.anchor;
    l.line.direction = (R * l.line.direction).normalized();
    l.information = R * l.information * R.transpose() / s2;
    if (l.restored_point) l.restored_point = S * *l.restored_point;
  }
  return out;
}

const mapping::StampedPose* NearestGroundTruthPose(const mapping::Trajectory& ground_truth,
                                                   double t, double max_time_difference) {
  const auto& gt = ground_truth.poses;
  auto it = std::lower_bound(gt.begin(), gt.end(), t,
                             [](const mapping::StampedPose& p, double x) { return p.timestamp < x; });
  const mapping::StampedPose* best = nullptr;
  if (it != gt.end()) best = &*it;
  if (it != gt.begin() && (!best || t - std::prev(it)->timestamp < best->timestamp - t)) {
    best = &*std::prev(it);
  }
  if (!best || std::abs(best->timestamp - t) > max_time_difference) return nullptr;
  return best;
}

std::optional<GroundTruthAlignment> AlignMapToGroundTruth(const slam::Map& map,
                                                          const mapping::Trajectory& ground_truth,
                                                          double max_time_difference,
                                                          std::string* problem) {
  // (timestamp, cam_from_world) of the map's keyframes.
  std::vector<std::pair<double, slam::Rigid3d>> poses;
  for (const auto& [id, kf] : map.keyframes) poses.emplace_back(kf.timestamp, kf.cam_from_world);
  if (poses.empty()) {
    for (const auto& [id, kf] : map.server_keyframes) {
      poses.emplace_back(kf.timestamp, kf.cam_from_world);
    }
  }
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<slam::Rigid3d> src_poses, dst_poses;
  for (const auto& [t, pose] : poses) {
    const mapping::StampedPose* best = NearestGroundTruthPose(ground_truth, t, max_time_difference);
    if (!best) continue;
    src.push_back(pose.Center());
    dst.push_back(best->cam_from_world.Center());
    src_poses.push_back(pose);
    dst_poses.push_back(best->cam_from_world);
  }
  if (src.size() < 3) {
    if (problem) {
      *problem = std::to_string(src.size()) + " keyframes matched the ground truth by timestamp";
    }
    return std::nullopt;
  }
  GroundTruthAlignment result;
  if (!slam::AlignUmeyama(src, dst, true, &result.gt_from_map)) {
    if (problem) *problem = "keyframe centres are degenerate (collinear or coincident)";
    return std::nullopt;
  }
  // Centres alone leave the rotation about a straight path (a street) nearly free: a second fit
  // adds, per keyframe, the points one lever arm along each camera axis (in map units on the
  // map side, times the first fit's scale on the ground-truth side), so the cameras' orientations
  // fix the rotation too. The lever arm is half the RMS spread of the centres.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& c : src) mean += c;
  mean /= src.size();
  double spread = 0.0;
  for (const auto& c : src) spread += (c - mean).squaredNorm();
  const double arm = 0.5 * std::sqrt(spread / src.size());
  std::vector<Eigen::Vector3d> src_axes = src, dst_axes = dst;
  for (size_t i = 0; i < src_poses.size(); ++i) {
    const Eigen::Matrix3d src_world_R_cam = src_poses[i].RotationMatrix().transpose();
    const Eigen::Matrix3d dst_world_R_cam = dst_poses[i].RotationMatrix().transpose();
    for (int axis = 0; axis < 3; ++axis) {
      src_axes.push_back(src[i] + arm * src_world_R_cam.col(axis));
      dst_axes.push_back(dst[i] + arm * result.gt_from_map.scale * dst_world_R_cam.col(axis));
    }
  }
  slam::Sim3d with_orientations;
  if (arm > 0.0 && slam::AlignUmeyama(src_axes, dst_axes, true, &with_orientations)) {
    result.gt_from_map = with_orientations;
  }
  result.matched = static_cast<int>(src.size());
  double sum = 0.0;
  for (size_t i = 0; i < src.size(); ++i) sum += (result.gt_from_map * src[i] - dst[i]).squaredNorm();
  result.rmse = std::sqrt(sum / src.size());
  return result;
}

}  // namespace lcv::privacy
