// The paper's prebuilt-map construction (privacy/map_ground_truth_poses.h): keyframes put on
// their ground-truth poses, points refined by BA on them. The SLAM map here is the synthetic
// street with its far end compressed along the street, as scale drift does; after the Sim(3)
// alignment the points are still off, after the refinement they are back near the scene.
#include "privacy/map_ground_truth_poses.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "mapping/synthetic_map.h"
#include "slam/util/error.h"

namespace lcv::privacy {
namespace {

// Compression along the street (z): z -> z (1 - kDrift z / length), applied to points and
// camera centres (orientations kept). The map is otherwise in the ground truth's frame, as
// `lcv map transform --sim3-align-to` leaves it (map_alignment_test covers the alignment).
constexpr double kDrift = 0.04;

struct Fixture {
  slam::Map truth;
  slam::Map slam_map;
  mapping::Trajectory ground_truth;
  slam::Id outlier_point = slam::kInvalidId;
};

Fixture MakeFixture() {
  mapping::SyntheticMapOptions options;
  options.num_points = 400;
  options.num_keyframes = 16;
  options.pixel_noise_px = 0.5;
  options.seed = 7;
  Fixture f;
  f.truth = mapping::MakeSyntheticPointMap(options);
  double length = 0.0;
  int k = 0;
  for (auto& [id, kf] : f.truth.keyframes) {
    kf.timestamp = 0.1 * k++;
    length = std::max(length, kf.cam_from_world.Center().z());
    f.ground_truth.poses.push_back({kf.timestamp, kf.cam_from_world});
  }
  const auto warp = [&](const Eigen::Vector3d& x) {
    Eigen::Vector3d y = x;
    y.z() = x.z() * (1.0 - kDrift * x.z() / length);
    return y;
  };
  f.slam_map = f.truth;
  for (auto& [id, kf] : f.slam_map.keyframes) {
    const Eigen::Vector3d centre = warp(kf.cam_from_world.Center());
    kf.cam_from_world.translation = -(kf.cam_from_world.rotation * centre);
  }
  for (auto& [id, p] : f.slam_map.points) p.position = warp(p.position);
  // A gross mismatch: one keypoint of one point 40 px away from where the point projects.
  for (auto& [id, p] : f.slam_map.points) {
    if (p.observations.size() < 3) continue;
    const slam::Observation& o = p.observations[0];
    f.slam_map.keyframes.at(o.keyframe_id).keypoints.at(o.keypoint_index).x += 40.f;
    f.outlier_point = id;
    break;
  }
  return f;
}

double MeanPointError(const slam::Map& map, const slam::Map& truth) {
  double sum = 0.0;
  for (const auto& [id, p] : map.points) sum += (p.position - truth.points.at(id).position).norm();
  return sum / map.points.size();
}

TEST(MapGroundTruthPoses, PutsKeyframesOnTheTruthAndPointsBackNearTheScene) {
  const Fixture f = MakeFixture();
  const slam::Map& aligned = f.slam_map;
  const double error_aligned = MeanPointError(aligned, f.truth);

  GroundTruthPosesReport report;
  GroundTruthPosesOptions structure_only;
  structure_only.refine_poses = false;
  const slam::Map refined =
      PutMapOnGroundTruthPoses(aligned, f.ground_truth, structure_only, "m", &report);
  EXPECT_EQ(report.max_pose_correction_m, 0.0);
  EXPECT_EQ(report.keyframes_on_ground_truth, 16);
  EXPECT_EQ(report.keyframes_kept, 0);
  for (const auto& [id, kf] : refined.keyframes) {
    EXPECT_LT((kf.cam_from_world.Center() - f.truth.keyframes.at(id).cam_from_world.Center()).norm(),
              1e-12);
  }
  const double error_refined = MeanPointError(refined, f.truth);
  EXPECT_GT(error_aligned, 0.1) << "the compression survives a Sim(3) alignment";
  EXPECT_LT(error_refined, 0.2 * error_aligned);
  EXPECT_LT(report.rms_px_after, report.rms_px_before);
  EXPECT_LT(report.rms_px_after, 1.5) << "0.5 px keypoint noise";

  // The mismatched keypoint is no longer an observation of its point.
  EXPECT_GE(report.observations_removed, 1);
  const slam::Observation moved = f.slam_map.points.at(f.outlier_point).observations[0];
  if (refined.points.count(f.outlier_point)) {
    for (const slam::Observation& o : refined.points.at(f.outlier_point).observations) {
      EXPECT_FALSE(o.keyframe_id == moved.keyframe_id && o.keypoint_index == moved.keypoint_index);
    }
  }
  for (const auto& [id, p] : refined.points) EXPECT_GE(p.observations.size(), 2u);
  EXPECT_EQ(report.points_out, static_cast<int>(refined.points.size()));

  // With the poses refined too (refine_poses): the first two keyframes stay on the ground truth,
  // the others move only by what the keypoint noise allows, and the points stay as good.
  GroundTruthPosesOptions with_poses;
  with_poses.refine_poses = true;
  GroundTruthPosesReport full_report;
  const slam::Map full =
      PutMapOnGroundTruthPoses(aligned, f.ground_truth, with_poses, "m", &full_report);
  auto kf = full.keyframes.begin();
  for (int i = 0; i < 2; ++i, ++kf) {
    EXPECT_LT((kf->second.cam_from_world.Center() -
               f.truth.keyframes.at(kf->first).cam_from_world.Center()).norm(), 1e-12);
  }
  EXPECT_GT(full_report.max_pose_correction_m, 0.0);
  EXPECT_LT(full_report.max_pose_correction_m, 0.1) << "metres, keyframes 1 m apart";
  EXPECT_LT(MeanPointError(full, f.truth), 0.2 * error_aligned);
  EXPECT_LE(full_report.rms_px_after, report.rms_px_after + 1e-9);
}

// The ground truth's camera frame turned by 1 degree against the camera that took the images
// (KITTI 00's case): the offset is estimated from the keyframes and the points come out as
// well as with an exact ground truth; without the estimate they do not fit.
TEST(MapGroundTruthPoses, EstimatesTheCameraRotationAgainstTheGroundTruth) {
  const Fixture f = MakeFixture();
  const Eigen::Quaterniond offset(Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d(1, 2, 0).normalized()));
  mapping::Trajectory turned = f.ground_truth;
  for (auto& pose : turned.poses) {
    // GT camera frame = offset^-1 * true camera frame, same centre.
    const Eigen::Vector3d centre = pose.cam_from_world.Center();
    pose.cam_from_world.rotation = offset.inverse() * pose.cam_from_world.rotation;
    pose.cam_from_world.translation = -(pose.cam_from_world.rotation * centre);
  }
  GroundTruthPosesOptions estimate;
  estimate.estimate_camera_rotation = true;
  GroundTruthPosesReport report;
  const slam::Map refined = PutMapOnGroundTruthPoses(f.slam_map, turned, estimate, "m", &report);
  EXPECT_NEAR(report.camera_rotation_offset_deg, 1.0, 1e-6);
  for (const auto& [id, kf] : refined.keyframes) {
    EXPECT_LT(kf.cam_from_world.rotation.angularDistance(f.truth.keyframes.at(id).cam_from_world.rotation),
              1e-9);
  }
  EXPECT_LT(report.rms_px_after, 1.5);

  GroundTruthPosesReport raw;
  PutMapOnGroundTruthPoses(f.slam_map, turned, GroundTruthPosesOptions{}, "m", &raw);
  EXPECT_EQ(raw.camera_rotation_offset_deg, 0.0);
  // Without it a 1 degree turn (8 px at f = 450 px) does not fit: many observations are lost
  // as outliers and the rest fit worse (measured: 263 removed against 1, 1.04 against 0.66 px).
  EXPECT_GT(raw.observations_removed, 20 * std::max(1, report.observations_removed));
  EXPECT_GT(raw.rms_px_after, report.rms_px_after);
}

TEST(MapGroundTruthPoses, RefusesLineCloudsAndUnmatchedTimestamps) {
  Fixture f = MakeFixture();
  mapping::Trajectory elsewhere = f.ground_truth;
  for (auto& pose : elsewhere.poses) pose.timestamp += 100.0;
  try {
    PutMapOnGroundTruthPoses(f.slam_map, elsewhere, GroundTruthPosesOptions{}, "m.lcmap");
    FAIL() << "no keyframe matches the ground truth";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("m.lcmap"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no keyframe"), std::string::npos) << e.what();
  }
  slam::LineLandmark line;
  line.id = f.slam_map.NextFreeId();
  line.line = slam::Line3d(Eigen::Vector3d(0, 0, 5), Eigen::Vector3d::UnitX());
  f.slam_map.lines[line.id] = line;
  EXPECT_THROW(
      PutMapOnGroundTruthPoses(f.slam_map, f.ground_truth, GroundTruthPosesOptions{}, "m.lcmap"),
      InputError);
}

}  // namespace
}  // namespace lcv::privacy
