#include "mapping/eval/trajectory_error.h"

#include <algorithm>
#include <cmath>

#include "slam/solve/umeyama.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// Rotation angle of a unit quaternion, in degrees, in [0, 180].
double AngleDeg(const Eigen::Quaterniond& q) {
  return 2.0 * std::atan2(q.vec().norm(), std::fabs(q.w())) * kRadToDeg;
}

// TrajectoryErrorReport::centre_spread_ratio of camera-to-world poses.
double CentreSpreadRatio(const std::vector<slam::Rigid3d>& world_from_cam) {
  std::vector<Eigen::Vector3d> centres;
  for (const slam::Rigid3d& pose : world_from_cam) centres.push_back(pose.translation);
  const Eigen::Vector3d scatter = slam::PrincipalScatter(centres);  // ascending
  if (!(scatter(2) > 0.0)) return 0.0;
  return std::sqrt(std::max(0.0, scatter(1)) / scatter(2));
}

// The associated poses as camera-to-world, the estimate aligned onto the ground truth.
struct MatchedPoses {
  std::vector<double> timestamps;
  std::vector<slam::Rigid3d> gt_world_from_cam;
  std::vector<slam::Rigid3d> est_world_from_cam;
};

// Steps 1 and 2; sets report->problem on failure.
MatchedPoses AssociateAndAlign(const Trajectory& gt, const Trajectory& est,
                               const TrajectoryErrorOptions& options,
                               TrajectoryErrorReport* report) {
  LCV_CHECK(options.max_time_difference_s >= 0.0) << options.max_time_difference_s;
  const TrajectoryAssociation association =
      AssociateByTimestamp(gt, est, options.max_time_difference_s);
  MatchedPoses matched;
  const int count = static_cast<int>(association.gt_indices.size());
  report->matched = count;
  if (count == 0) {
    report->problem = "no poses associated within " + std::to_string(options.max_time_difference_s) +
                      " s (check the timestamps, --t-max-diff, or --times for KITTI files)";
    return matched;
  }
  for (int k = 0; k < count; ++k) {
    const StampedPose& g = gt.poses[association.gt_indices[k]];
    const StampedPose& e = est.poses[association.est_indices[k]];
    matched.timestamps.push_back(g.timestamp);
    matched.gt_world_from_cam.push_back(g.cam_from_world.Inverse());
    matched.est_world_from_cam.push_back(e.cam_from_world.Inverse());
  }
  report->centre_spread_ratio = CentreSpreadRatio(matched.gt_world_from_cam);
  report->gt_from_est = slam::Sim3d();
  if (options.alignment != TrajectoryAlignment::kNone) {
    const bool with_scale = options.alignment == TrajectoryAlignment::kSim3;
    slam::Sim3d gt_from_est;
    if (options.align_with_orientations) {
      std::vector<slam::Rigid3d> est_cam_from_world, gt_cam_from_world;
      for (int k = 0; k < count; ++k) {
        est_cam_from_world.push_back(matched.est_world_from_cam[k].Inverse());
        gt_cam_from_world.push_back(matched.gt_world_from_cam[k].Inverse());
      }
      if (!slam::AlignPoseSets(est_cam_from_world, gt_cam_from_world, with_scale,
                               &gt_from_est)) {
        report->problem = "alignment degenerate: " + std::to_string(count) +
                          " matched poses, at least 2 with distinct camera centres needed";
        return matched;
      }
    } else {
      std::vector<Eigen::Vector3d> est_centres, gt_centres;
      for (int k = 0; k < count; ++k) {
        est_centres.push_back(matched.est_world_from_cam[k].translation);
        gt_centres.push_back(matched.gt_world_from_cam[k].translation);
      }
      if (!slam::AlignUmeyama(est_centres, gt_centres, with_scale, &gt_from_est)) {
        report->problem = "alignment degenerate: " + std::to_string(count) +
                          " matched poses, at least 3 with non-collinear camera centres needed";
        return matched;
      }
    }
    report->gt_from_est = gt_from_est;
    for (auto& pose : matched.est_world_from_cam) {
      pose = slam::Rigid3d(gt_from_est.rotation * pose.rotation, gt_from_est * pose.translation);
    }
  }
  return matched;
}

void AddError(double timestamp, const slam::Rigid3d& gt_world_from_cam,
              const slam::Rigid3d& est_world_from_cam, const slam::Rigid3d& error,
              TrajectoryErrorReport* report) {
  report->timestamps.push_back(timestamp);
  report->gt_centres.push_back(gt_world_from_cam.translation);
  report->est_centres.push_back(est_world_from_cam.translation);
  report->translation_errors.push_back(error.translation.norm());
  report->rotation_errors_deg.push_back(AngleDeg(error.rotation));
}

void Summarize(TrajectoryErrorReport* report) {
  report->translation = ComputeErrorStatistics(report->translation_errors);
  report->rotation_deg = ComputeErrorStatistics(report->rotation_errors_deg);
}

}  // namespace

std::optional<TrajectoryAlignment> ParseTrajectoryAlignment(const std::string& name) {
  if (name == "none") return TrajectoryAlignment::kNone;
  if (name == "se3") return TrajectoryAlignment::kSE3;
  if (name == "sim3") return TrajectoryAlignment::kSim3;
  return std::nullopt;
}

const char* TrajectoryAlignmentName(TrajectoryAlignment alignment) {
  switch (alignment) {
    case TrajectoryAlignment::kNone: return "none";
    case TrajectoryAlignment::kSE3: return "se3";
    case TrajectoryAlignment::kSim3: return "sim3";
  }
  return "none";
}

TrajectoryAssociation AssociateByTimestamp(const Trajectory& gt, const Trajectory& est,
                                           double max_time_difference_s) {
  // evo matches every pose of the shorter trajectory (the first one when equally long) to its
  // nearest neighbour in time in the longer one.
  const bool est_longer = est.poses.size() > gt.poses.size();
  const std::vector<StampedPose>& shorter = est_longer ? gt.poses : est.poses;
  const std::vector<StampedPose>& longer = est_longer ? est.poses : gt.poses;
  TrajectoryAssociation association;
  if (longer.empty()) return association;
  std::vector<int>& shorter_indices = est_longer ? association.gt_indices : association.est_indices;
  std::vector<int>& longer_indices = est_longer ? association.est_indices : association.gt_indices;
  for (size_t i = 0; i < shorter.size(); ++i) {
    const double t = shorter[i].timestamp;
    const auto it = std::lower_bound(
        longer.begin(), longer.end(), t,
        [](const StampedPose& pose, double value) { return pose.timestamp < value; });
    size_t best = static_cast<size_t>(it - longer.begin());
    // Nearest of the neighbours either side; the earlier one on ties (numpy argmin).
    if (best == longer.size() ||
        (best > 0 && std::fabs(longer[best - 1].timestamp - t) <=
                         std::fabs(longer[best].timestamp - t))) {
      --best;
    }
    if (std::fabs(longer[best].timestamp - t) <= max_time_difference_s) {
      shorter_indices.push_back(static_cast<int>(i));
      longer_indices.push_back(static_cast<int>(best));
    }
  }
  return association;
}

ErrorStatistics ComputeErrorStatistics(std::vector<double> values) {
  ErrorStatistics stats;
  stats.count = static_cast<int>(values.size());
  if (values.empty()) return stats;
  double sum = 0.0;
  for (const double v : values) {
    sum += v;
    stats.sse += v * v;
  }
  const double n = static_cast<double>(values.size());
  stats.mean = sum / n;
  stats.rmse = std::sqrt(stats.sse / n);
  double variance = 0.0;
  for (const double v : values) variance += (v - stats.mean) * (v - stats.mean);
  stats.std = std::sqrt(variance / n);
  std::sort(values.begin(), values.end());
  stats.min = values.front();
  stats.max = values.back();
  const size_t mid = values.size() / 2;
  stats.median = values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
  return stats;
}

TrajectoryErrorReport ComputeApe(const Trajectory& gt, const Trajectory& est,
                                 const TrajectoryErrorOptions& options) {
  TrajectoryErrorReport report;
  const MatchedPoses poses = AssociateAndAlign(gt, est, options, &report);
  if (report.problem) return report;
  for (size_t k = 0; k < poses.timestamps.size(); ++k) {
    AddError(poses.timestamps[k], poses.gt_world_from_cam[k], poses.est_world_from_cam[k],
             poses.gt_world_from_cam[k].Inverse() * poses.est_world_from_cam[k], &report);
  }
  Summarize(&report);
  return report;
}

TrajectoryErrorReport ComputeRpe(const Trajectory& gt, const Trajectory& est,
                                 const TrajectoryErrorOptions& options) {
  LCV_CHECK(options.rpe_delta >= 1) << options.rpe_delta;
  TrajectoryErrorReport report;
  const MatchedPoses poses = AssociateAndAlign(gt, est, options, &report);
  if (report.problem) return report;
  const size_t count = poses.timestamps.size();
  const size_t delta = static_cast<size_t>(options.rpe_delta);
  const size_t step = options.rpe_all_pairs ? 1 : delta;
  for (size_t i = 0; i + delta < count; i += step) {
    const size_t j = i + delta;
    const slam::Rigid3d gt_relative =
        poses.gt_world_from_cam[i].Inverse() * poses.gt_world_from_cam[j];
    const slam::Rigid3d est_relative =
        poses.est_world_from_cam[i].Inverse() * poses.est_world_from_cam[j];
    AddError(poses.timestamps[i], poses.gt_world_from_cam[i], poses.est_world_from_cam[i],
             gt_relative.Inverse() * est_relative, &report);
  }
  if (report.timestamps.empty()) {
    report.problem = "no pose pairs: " + std::to_string(count) + " matched poses for delta " +
                     std::to_string(delta);
    return report;
  }
  Summarize(&report);
  return report;
}

}  // namespace lcv::mapping
