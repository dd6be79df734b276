#include "slam/module/loop_closer.h"

#include <algorithm>
#include <cstdio>

#include <gtest/gtest.h>

#include "slam/data/frame_anchor.h"
#include "slam/module/global_bundle_adjustment.h"
#include "tests/slam/module/loop_scene.h"

namespace lcv::slam {
namespace {

using testing::LoopScene;
using testing::LoopSceneOptions;
using testing::MakeLoopScene;

// Keyframes enter the database one by one before their query, as in System.
std::optional<LoopDetection> FirstDetection(const LoopScene& s) {
  LoopDetector detector;
  BowDatabase database;
  for (const Id id : s.keyframe_ids) {
    database.Add(id, s.map.keyframes().at(id).bow);
    std::optional<LoopDetection> loop = detector.Detect(s.map, database, id, 3);
    if (loop) return loop;
  }
  return std::nullopt;
}

// Scene points seen through more than one landmark (the revisit's duplicates).
int CountDuplicatedPoints(const LoopScene& s) {
  std::map<int, int> landmarks_per_point;
  for (const auto& [id, landmark] : s.map.landmarks()) {
    ++landmarks_per_point[s.point_of_landmark.at(id)];
  }
  int duplicated = 0;
  for (const auto& [point, count] : landmarks_per_point) duplicated += count > 1;
  return duplicated;
}

TEST(CorrectLoop, RemovesTheDriftAndFusesTheDuplicates) {
  const LoopSceneOptions options;
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  ASSERT_EQ(testing::MapProblem(s->map), "");
  const std::optional<LoopDetection> loop = FirstDetection(*s);
  ASSERT_TRUE(loop) << "seed " << options.seed;

  const double rmse_before = testing::AlignedTrajectoryRmse(*s);
  const int duplicated_before = CountDuplicatedPoints(*s);
  const size_t landmarks_before = s->map.landmarks().size();
  const LoopCorrectionReport report = CorrectLoop(*loop, LoopCloserOptions(), &s->map);
  const double rmse_after = testing::AlignedTrajectoryRmse(*s);
  const int duplicated_after = CountDuplicatedPoints(*s);
  std::printf("aligned keyframe-centre RMSE %.4f m -> %.4f m; %d fused, %d keyframes corrected, "
              "%d essential edges, pose graph %d iterations; points with duplicates %d -> %d; "
              "landmarks %zu -> %zu; %.1f ms\n",
              rmse_before, rmse_after, report.num_fused, report.num_keyframes_corrected,
              report.num_edges, report.pose_graph.num_iterations, duplicated_before,
              duplicated_after, landmarks_before, s->map.landmarks().size(), report.time_ms);
  ASSERT_TRUE(report.success);
  EXPECT_TRUE(report.pose_graph.success) << report.pose_graph.message;
  EXPECT_EQ(testing::MapProblem(s->map), "");
  EXPECT_GT(rmse_before, 0.15);
  EXPECT_LT(rmse_after, 0.35 * rmse_before);  // measured: 0.243 m -> 0.065 m
  EXPECT_GE(report.num_fused, 40);
  EXPECT_LT(duplicated_after, duplicated_before);
  EXPECT_TRUE(s->map.HasLoopEdge(loop->query_keyframe_id));
  EXPECT_TRUE(s->map.HasLoopEdge(loop->match_keyframe_id));
  // Query and match are covisible now (they share the fused landmarks).
  EXPECT_TRUE(s->map.keyframes().at(loop->query_keyframe_id).covisibility_weights.count(
      loop->match_keyframe_id));

  // Every landmark reprojects near its keypoints: the map is consistent again at the loop.
  int observations = 0, far = 0;
  for (const auto& [id, landmark] : s->map.landmarks()) {
    for (const Observation& o : landmark.observations) {
      const SlamKeyframe& kf = s->map.keyframes().at(o.keyframe_id);
      const auto px = kf.camera->Project(kf.cam_from_world * landmark.position_in_world);
      const Keypoint& kp = kf.keypoints[o.keypoint_index];
      ++observations;
      far += !px || (*px - Eigen::Vector2d(kp.x, kp.y)).norm() > 20.0;
    }
  }
  std::printf("observations reprojecting > 20 px off: %d of %d\n", far, observations);
}

// The whole loop-closing sequence of System: detection, correction, then global BA over the
// corrected map (which also removes the inconsistency the drift ramp left in the map).
TEST(CorrectLoop, GlobalBundleAdjustmentAfterTheCorrectionLowersTheErrorFurther) {
  const std::unique_ptr<LoopScene> s = MakeLoopScene(LoopSceneOptions());
  const std::optional<LoopDetection> loop = FirstDetection(*s);
  ASSERT_TRUE(loop);
  ASSERT_TRUE(CorrectLoop(*loop, LoopCloserOptions(), &s->map).success);
  const double rmse_corrected = testing::AlignedTrajectoryRmse(*s);
  GlobalBAJob job = CaptureGlobalBA(s->map);
  const BundleReport report = SolveGlobalBA(GlobalBAOptions(), &job);
  ASSERT_TRUE(report.success) << report.message;
  ASSERT_TRUE(ApplyGlobalBA(job, &s->map));
  const double rmse_adjusted = testing::AlignedTrajectoryRmse(*s);
  std::printf("aligned keyframe-centre RMSE after correction %.4f m, after global BA %.4f m "
              "(%d outliers, %.0f ms)\n",
              rmse_corrected, rmse_adjusted, report.num_outliers, report.time_ms);
  EXPECT_LT(rmse_adjusted, 0.5 * rmse_corrected);
  EXPECT_EQ(testing::MapProblem(s->map), "");
}

// Tracking records frames as rigid offsets from a keyframe. The drift grew the map 12% around
// the query; after the correction a frame recorded against the query must come out at its true
// distance from it, not 12% too far (SlamKeyframe::scale, slam/data/frame_anchor.h).
TEST(CorrectLoop, FramesRecordedAgainstAKeyframeFollowItsScaleCorrection) {
  const LoopSceneOptions options;
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  const std::optional<LoopDetection> loop = FirstDetection(*s);
  ASSERT_TRUE(loop);
  const int k = static_cast<int>(std::find(s->keyframe_ids.begin(), s->keyframe_ids.end(),
                                           loop->query_keyframe_id) -
                                 s->keyframe_ids.begin());
  ASSERT_GE(k, options.drift_end) << "the query is in the fully drifted part";
  const Id query = loop->query_keyframe_id;
  // A frame 1.2 m beside and 0.5 m ahead of the query (truth), seen through the drift.
  const Rigid3d true_frame =
      Rigid3d(ExpSO3(Eigen::Vector3d(0.0, 0.1, 0.0)), Eigen::Vector3d(-1.2, 0.0, -0.5)) *
      s->true_cam_from_world[k];
  const Rigid3d drifted_frame = TransformPose(s->drift[k], true_frame);
  const SlamKeyframe& before = s->map.keyframes().at(query);
  const Rigid3d frame_from_query = drifted_frame * before.cam_from_world.Inverse();
  const double recorded_scale = before.scale;
  const double true_distance =
      (true_frame.Center() - s->true_cam_from_world[k].Center()).norm();
  ASSERT_NEAR(frame_from_query.translation.norm() / true_distance, options.drift_scale, 1e-6);

  ASSERT_TRUE(CorrectLoop(*loop, LoopCloserOptions(), &s->map).success);
  const SlamKeyframe& after = s->map.keyframes().at(query);
  EXPECT_NEAR(after.scale, 1.0 / options.drift_scale, 0.03);
  const std::optional<Rigid3d> anchored =
      AnchoredFramePose(s->map, query, frame_from_query, recorded_scale);
  ASSERT_TRUE(anchored);
  const double distance = (anchored->Center() - after.cam_from_world.Center()).norm();
  EXPECT_NEAR(distance / true_distance, 1.0, 0.03);
  // The rotation part of the offset is untouched.
  EXPECT_NEAR(anchored->rotation.angularDistance(
                  frame_from_query.rotation * after.cam_from_world.rotation),
              0.0, 1e-9);
}

// Two and a bit laps: the second revisit is closed with the first loop's edge in the essential
// graph, and the map stays consistent.
TEST(CorrectLoop, ASecondLoopKeepsTheFirstLoopEdge) {
  LoopSceneOptions options;
  options.num_keyframes = 88;
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  const double rmse_before = testing::AlignedTrajectoryRmse(*s);
  LoopDetector detector;
  BowDatabase database;
  std::vector<LoopDetection> closed;
  for (const Id id : s->keyframe_ids) {
    database.Add(id, s->map.keyframes().at(id).bow);
    const std::optional<LoopDetection> loop = detector.Detect(s->map, database, id, 5);
    if (!loop) continue;
    const LoopCorrectionReport report = CorrectLoop(*loop, LoopCloserOptions(), &s->map);
    ASSERT_TRUE(report.success);
    EXPECT_TRUE(report.pose_graph.success) << report.pose_graph.message;
    ASSERT_EQ(testing::MapProblem(s->map), "") << "after loop " << closed.size();
    closed.push_back(*loop);
    std::printf("loop %zu: query keyframe %lld, match keyframe %lld, %d fused\n", closed.size(),
                static_cast<long long>(loop->query_keyframe_id),
                static_cast<long long>(loop->match_keyframe_id), report.num_fused);
  }
  ASSERT_GE(closed.size(), 2u);
  EXPECT_EQ(s->map.loop_edges().size(), closed.size());
  const double rmse = testing::AlignedTrajectoryRmse(*s);
  std::printf("%zu loops closed; aligned keyframe-centre RMSE %.4f m -> %.4f m\n", closed.size(),
              rmse_before, rmse);
  EXPECT_LT(rmse, 0.5 * rmse_before);
}

TEST(CorrectLoop, UnknownKeyframesChangeNothing) {
  LoopSceneOptions options;
  options.num_keyframes = 12;
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  LoopDetection loop;
  loop.query_keyframe_id = s->keyframe_ids.back();
  loop.match_keyframe_id = 1 << 30;
  const Rigid3d before = s->map.keyframes().at(loop.query_keyframe_id).cam_from_world;
  EXPECT_FALSE(CorrectLoop(loop, LoopCloserOptions(), &s->map).success);
  EXPECT_TRUE(s->map.loop_edges().empty());
  EXPECT_EQ(s->map.keyframes().at(loop.query_keyframe_id).cam_from_world.translation,
            before.translation);
}

}  // namespace
}  // namespace lcv::slam
