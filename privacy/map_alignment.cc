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

std::optional<GroundTruthAlignment> AlignMapToGroundTruth(const slam::Map& map,
                                                          const mapping::Trajectory& ground_truth,
                                                          double max_time_difference,
                                                          std::string* problem) {
  std::vector<std::pair<double, Eigen::Vector3d>> centres;  // (timestamp, centre) of the map
  for (const auto& [id, kf] : map.keyframes) {
    centres.emplace_back(kf.timestamp, kf.cam_from_world.Center());
  }
  if (centres.empty()) {
    for (const auto& [id, kf] : map.server_keyframes) {
      centres.emplace_back(kf.timestamp, kf.cam_from_world.Center());
    }
  }
  std::vector<Eigen::Vector3d> src, dst;
  const auto& gt = ground_truth.poses;
  for (const auto& [t, centre] : centres) {
    // Ground-truth timestamps increase (trajectory.h): binary search the nearest.
    auto it = std::lower_bound(gt.begin(), gt.end(), t,
                               [](const mapping::StampedPose& p, double x) { return p.timestamp < x; });
    const mapping::StampedPose* best = nullptr;
    if (it != gt.end()) best = &*it;
    if (it != gt.begin() && (!best || t - std::prev(it)->timestamp < best->timestamp - t)) {
      best = &*std::prev(it);
    }
    if (!best || std::abs(best->timestamp - t) > max_time_difference) continue;
    src.push_back(centre);
    dst.push_back(best->cam_from_world.Center());
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
  result.matched = static_cast<int>(src.size());
  double sum = 0.0;
  for (size_t i = 0; i < src.size(); ++i) sum += (result.gt_from_map * src[i] - dst[i]).squaredNorm();
  result.rmse = std::sqrt(sum / src.size());
  return result;
}

}  // namespace lcv::privacy
