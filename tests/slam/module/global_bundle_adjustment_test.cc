#include "slam/module/global_bundle_adjustment.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "tests/slam/module/loop_scene.h"

namespace lcv::slam {
namespace {

using testing::LoopScene;
using testing::LoopSceneOptions;
using testing::MakeLoopScene;

// A short arc of the ring without drift, with noisy landmarks and keyframe poses (all but the
// first keyframe).
std::unique_ptr<LoopScene> NoisyArc(std::uint64_t seed) {
  LoopSceneOptions options;
  options.num_keyframes = 14;
  options.drift_start = options.drift_end = 1000;
  options.position_noise_m = 0.05;
  options.seed = seed;
  std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  std::mt19937_64 rng(seed + 1);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (size_t k = 1; k < s->keyframe_ids.size(); ++k) {
    Vector6d delta;
    for (int d = 0; d < 3; ++d) delta(d) = 0.05 * normal(rng);
    for (int d = 3; d < 6; ++d) delta(d) = 0.005 * normal(rng);
    Rigid3d& pose = s->map.FindKeyframe(s->keyframe_ids[k])->cam_from_world;
    pose = Rigid3d::Exp(delta) * pose;
  }
  return s;
}

double ReprojectionRms(const SlamMap& map) {
  double sum = 0.0;
  int count = 0;
  for (const auto& [id, landmark] : map.landmarks()) {
    for (const Observation& o : landmark.observations) {
      const SlamKeyframe& kf = map.keyframes().at(o.keyframe_id);
      const auto px = kf.camera->Project(kf.cam_from_world * landmark.position_in_world);
      if (!px) continue;
      const Keypoint& kp = kf.keypoints[o.keypoint_index];
      sum += (*px - Eigen::Vector2d(kp.x, kp.y)).squaredNorm();
      ++count;
    }
  }
  return std::sqrt(sum / std::max(1, count));
}

TEST(GlobalBundleAdjustment, CaptureSolveApplyReducesTheErrors) {
  const std::unique_ptr<LoopScene> s = NoisyArc(31);
  const double rms_before = ReprojectionRms(s->map);
  const double rmse_before = testing::AlignedTrajectoryRmse(*s);
  GlobalBAJob job = CaptureGlobalBA(s->map);
  EXPECT_EQ(job.problem.keyframes.size(), s->map.keyframes().size());
  EXPECT_EQ(job.problem.points.size(), s->map.landmarks().size());
  EXPECT_EQ(job.links.size(), job.problem.observations.size());
  const BundleReport report = SolveGlobalBA(GlobalBAOptions(), &job);
  ASSERT_TRUE(report.success) << report.message;
  // Solve does not touch the map.
  EXPECT_EQ(ReprojectionRms(s->map), rms_before);
  EXPECT_TRUE(ApplyGlobalBA(job, &s->map));
  const double rms_after = ReprojectionRms(s->map);
  const double rmse_after = testing::AlignedTrajectoryRmse(*s);
  std::printf("reprojection RMS %.2f px -> %.2f px; aligned centre RMSE %.4f m -> %.4f m; "
              "%d outliers; %.0f ms\n",
              rms_before, rms_after, rmse_before, rmse_after, report.num_outliers,
              report.time_ms);
  EXPECT_LT(rms_after, 1.0);  // pixel noise 0.5 px
  EXPECT_LT(rmse_after, 0.3 * rmse_before);
  EXPECT_EQ(testing::MapProblem(s->map), "");
}

TEST(GlobalBundleAdjustment, ApplyMovesAKeyframeAddedAfterCaptureWithItsParent) {
  const std::unique_ptr<LoopScene> s = NoisyArc(32);
  GlobalBAJob job = CaptureGlobalBA(s->map);
  SolveGlobalBA(GlobalBAOptions(), &job);
  ASSERT_TRUE(job.report.success);

  // Meanwhile local mapping adds a keyframe (half a step past the last one) that sees some
  // captured landmarks and creates one of its own; and erases a landmark and a keyframe.
  const int last = static_cast<int>(s->keyframe_ids.size()) - 1;
  const Id last_id = s->keyframe_ids[last];
  Frame frame;
  frame.id = 100;
  frame.camera = s->camera.get();
  frame.keypoints = s->map.keyframes().at(last_id).keypoints;
  frame.descriptors = s->map.keyframes().at(last_id).descriptors;
  frame.cam_from_world =
      Rigid3d::Exp((Vector6d() << 0.1, 0.0, 0.0, 0.0, 0.02, 0.0).finished()) *
      s->map.keyframes().at(last_id).cam_from_world;
  PrepareFrame(&frame);
  const Id new_id = s->map.AddKeyframe(frame).id;
  const std::vector<Id> last_landmarks = s->map.keyframes().at(last_id).landmark_ids;
  int linked = 0;
  for (size_t i = 0; i < last_landmarks.size(); ++i) {
    if (last_landmarks[i] == kInvalidId) continue;
    linked += s->map.AddObservation(last_landmarks[i], new_id, static_cast<int>(i));
  }
  ASSERT_GT(linked, 30);
  int free_keypoint = -1;
  for (size_t i = 0; i < last_landmarks.size() && free_keypoint < 0; ++i) {
    if (last_landmarks[i] == kInvalidId) free_keypoint = static_cast<int>(i);
  }
  ASSERT_GE(free_keypoint, 0);
  const Eigen::Vector3d new_point_in_cam(0.3, -0.2, 6.0);
  const Id new_landmark =
      s->map.AddLandmark(frame.cam_from_world.Inverse() * new_point_in_cam, new_id).id;
  s->map.AddObservation(new_landmark, new_id, free_keypoint);
  s->map.AddObservation(new_landmark, last_id, free_keypoint);
  s->map.UpdateLandmarkGeometry(new_landmark);
  s->map.UpdateCovisibility(new_id);
  const Id parent_id = s->map.keyframes().at(new_id).parent_id;
  ASSERT_NE(parent_id, kInvalidId);
  const Rigid3d new_from_parent =
      frame.cam_from_world * s->map.keyframes().at(parent_id).cam_from_world.Inverse();
  const Id erased_keyframe = s->keyframe_ids[5];
  s->map.EraseKeyframe(erased_keyframe);
  const Id erased_landmark = s->map.landmarks().begin()->first;
  s->map.EraseLandmark(erased_landmark);

  ApplyGlobalBA(job, &s->map);
  EXPECT_EQ(testing::MapProblem(s->map), "");
  EXPECT_EQ(s->map.FindKeyframe(erased_keyframe), nullptr);
  EXPECT_EQ(s->map.FindLandmark(erased_landmark), nullptr);
  const Rigid3d& new_pose = s->map.keyframes().at(new_id).cam_from_world;
  const Rigid3d& parent_pose = s->map.keyframes().at(parent_id).cam_from_world;
  // The parent moved (it was optimized) and the new keyframe kept its pose relative to it.
  EXPECT_GT((parent_pose.Center() - job.problem.keyframes.front().cam_from_world.Center()).norm(),
            0.0);
  const Rigid3d relative = new_pose * parent_pose.Inverse();
  EXPECT_LT((relative.translation - new_from_parent.translation).norm(), 1e-9);
  EXPECT_LT(AngularDistance(relative.rotation, new_from_parent.rotation), 1e-9);
  EXPECT_GT((new_pose.Center() - frame.cam_from_world.Center()).norm(), 1e-4);
  // The new landmark moved with its reference keyframe (the new one).
  const Eigen::Vector3d in_cam =
      new_pose * s->map.landmarks().at(new_landmark).position_in_world;
  EXPECT_LT((in_cam - new_point_in_cam).norm(), 1e-9);
}

TEST(GlobalBundleAdjustment, OutlierObservationsAreUnlinked) {
  const std::unique_ptr<LoopScene> s = NoisyArc(33);
  // Move one observed keypoint by 80 px across the (horizontal) epipolar lines, so that no depth
  // of the point explains it: its observation must come out as an outlier.
  const Id kf_id = s->keyframe_ids[4];
  SlamKeyframe* kf = s->map.FindKeyframe(kf_id);
  int index = -1;
  for (size_t i = 0; i < kf->landmark_ids.size() && index < 0; ++i) {
    const SlamLandmark* landmark = s->map.FindLandmark(kf->landmark_ids[i]);
    if (landmark != nullptr && landmark->NumObservations() >= 4) index = static_cast<int>(i);
  }
  ASSERT_GE(index, 0);
  const Id landmark_id = kf->landmark_ids[index];
  kf->keypoints.mutate()[index].y += kf->keypoints[index].y > 240 ? -80.f : 80.f;
  GlobalBAJob job = CaptureGlobalBA(s->map);
  SolveGlobalBA(GlobalBAOptions(), &job);
  ASSERT_TRUE(job.report.success);
  EXPECT_GE(job.report.num_outliers, 1);
  ApplyGlobalBA(job, &s->map);
  EXPECT_EQ(s->map.keyframes().at(kf_id).landmark_ids[index], kInvalidId);
  ASSERT_NE(s->map.FindLandmark(landmark_id), nullptr);  // still seen by >= 3 keyframes
  EXPECT_EQ(testing::MapProblem(s->map), "");
}

TEST(GlobalBundleAdjustment, UnsolvedOrStaleJobChangesNothing) {
  const std::unique_ptr<LoopScene> s = NoisyArc(34);
  const double rms_before = ReprojectionRms(s->map);
  GlobalBAJob job = CaptureGlobalBA(s->map);
  EXPECT_FALSE(ApplyGlobalBA(job, &s->map));
  EXPECT_EQ(ReprojectionRms(s->map), rms_before);
  // Solved, but a loop was closed meanwhile: stale.
  SolveGlobalBA(GlobalBAOptions(), &job);
  s->map.AddLoopEdge(s->keyframe_ids.back(), s->keyframe_ids.front());
  EXPECT_FALSE(ApplyGlobalBA(job, &s->map));
  EXPECT_EQ(ReprojectionRms(s->map), rms_before);
}

}  // namespace
}  // namespace lcv::slam
