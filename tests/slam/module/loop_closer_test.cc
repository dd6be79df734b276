#include "slam/module/loop_closer.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <gtest/gtest.h>

#include "slam/data/frame_anchor.h"
#include "slam/geometry/so3.h"
#include "slam/module/global_bundle_adjustment.h"
#include "tests/slam/module/loop_scene.h"
#include "tests/slam/system/synthetic_features.h"

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

// The keyframes before the drift (exact, in the truth's frame) play a map read from a file.
// Returns their ids and centres.
std::map<Id, Eigen::Vector3d> MarkUndriftedKeyframesLoaded(const LoopSceneOptions& options,
                                                          LoopScene* s) {
  std::map<Id, Eigen::Vector3d> centres;
  for (int k = 0; k < options.drift_start; ++k) {
    SlamKeyframe& kf = s->map.mutable_keyframes().at(s->keyframe_ids[k]);
    kf.loaded = true;
    centres[kf.id] = kf.Center();
  }
  return centres;
}

// The similarity that takes the loaded keyframes' centres now back onto `before`, as the sum of
// its translation (m), rotation (rad) and |scale - 1|: zero when the loaded map kept its datum.
double DatumMotion(const LoopScene& s, const std::map<Id, Eigen::Vector3d>& before) {
  std::vector<Eigen::Vector3d> now, then;
  for (const auto& [id, centre] : before) {
    now.push_back(s.map.keyframes().at(id).Center());
    then.push_back(centre);
  }
  Sim3d then_from_now;
  EXPECT_TRUE(AlignUmeyama(now, then, true, &then_from_now));
  return then_from_now.translation.norm() +
         AngularDistance(then_from_now.rotation, Eigen::Quaterniond::Identity()) +
         std::abs(then_from_now.scale - 1.0);
}

// Keyframe-centre RMSE against the truth without alignment: the loaded keyframes are in the
// truth's frame, so this is the error in the loaded map's frame.
double RmseInTruthFrame(const LoopScene& s) {
  double sum = 0.0;
  for (size_t k = 0; k < s.keyframe_ids.size(); ++k) {
    sum += (s.map.keyframes().at(s.keyframe_ids[k]).Center() - s.true_cam_from_world[k].Center())
               .squaredNorm();
  }
  return std::sqrt(sum / s.keyframe_ids.size());
}

// A loop closed in a loaded map: without the datum the essential graph spreads the loop's error
// over the whole cycle and the loaded map moves as a whole; with it (the engine's default,
// LoopClosing.keep_loaded_datum) the loaded keyframes' similarity fit is the identity, the
// drift is removed as well, and the error in the map's frame is lower. Then global BA keeps the
// datum the same way.
TEST(CorrectLoop, KeepsTheDatumOfALoadedMap) {
  const LoopSceneOptions options;
  double motion[2], rmse_in_map_frame[2];
  for (const bool datum : {false, true}) {
    SCOPED_TRACE(datum ? "loaded datum kept" : "no datum");
    const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
    const std::map<Id, Eigen::Vector3d> loaded = MarkUndriftedKeyframesLoaded(options, s.get());
    const std::optional<LoopDetection> loop = FirstDetection(*s);
    ASSERT_TRUE(loop);
    ASSERT_TRUE(loaded.count(loop->match_keyframe_id)) << "the loop closes on the loaded part";
    const double aligned_before = testing::AlignedTrajectoryRmse(*s);
    LoopCloserOptions closer;
    closer.keep_loaded_datum = datum;
    ASSERT_TRUE(CorrectLoop(*loop, closer, &s->map).success);
    EXPECT_EQ(testing::MapProblem(s->map), "");
    motion[datum] = DatumMotion(*s, loaded);
    rmse_in_map_frame[datum] = RmseInTruthFrame(*s);
    const double aligned_after = testing::AlignedTrajectoryRmse(*s);
    std::printf("%s: loaded map moved by %.2e (m + rad + scale), RMSE in its frame %.4f m, "
                "aligned %.4f -> %.4f m\n",
                datum ? "datum" : "no datum", motion[datum], rmse_in_map_frame[datum],
                aligned_before, aligned_after);
    EXPECT_LT(aligned_after, 0.35 * aligned_before);

    if (!datum) continue;
    GlobalBACaptureOptions capture;
    capture.keep_loaded_datum = true;
    GlobalBAJob job = CaptureGlobalBA(s->map, capture);
    ASSERT_EQ(job.loaded_keyframes.size(), loaded.size());
    std::map<Id, Eigen::Vector3d> before_ba;
    for (const auto& [id, centre] : loaded) before_ba[id] = s->map.keyframes().at(id).Center();
    ASSERT_TRUE(SolveGlobalBA(GlobalBAOptions(), &job).success);
    ASSERT_TRUE(ApplyGlobalBA(job, &s->map));
    EXPECT_LT(DatumMotion(*s, before_ba), 1e-6);
    EXPECT_LT(testing::AlignedTrajectoryRmse(*s), aligned_after);
  }
  EXPECT_GT(motion[false], 0.05);  // the scene moves the loaded map when nothing holds it
  EXPECT_LT(motion[true], 1e-6);
  EXPECT_LT(rmse_in_map_frame[true], rmse_in_map_frame[false]);
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

// A map kept after tracking was lost (segment 0) and a new one (segment 1) that sees the same
// views in a frame 2.5x larger, rotated and shifted. The detection's Sim(3) maps segment 0's
// world into the query camera in segment 1's units; the merge must put every keyframe and point
// of segment 1 back on segment 0's frame.
TEST(MergeSegmentsForLoop, MovesTheNewMapOntoTheKeptOne) {
  const std::unique_ptr<Camera> camera = MakeCamera(testing::SyntheticPinhole());
  const Sim3d new_from_kept(2.5, Eigen::Quaterniond(ExpSO3(Eigen::Vector3d(0.3, -0.2, 0.9))),
                            Eigen::Vector3d(-4.0, 1.0, 7.0));
  const std::vector<Rigid3d> truth = testing::MakeLateralTrajectory(4, 0.4);
  const Eigen::Vector3d point_in_kept(0.3, -0.2, 5.0);
  SlamMap map;
  const auto add_keyframe = [&](const Rigid3d& cam_from_world, int frame_id) {
    Frame frame;
    frame.id = frame_id;
    frame.camera = camera.get();
    frame.cam_from_world = cam_from_world;
    frame.keypoints = {Keypoint{320.f, 240.f, 0.f, 0}};
    frame.descriptors = {OrbDescriptor{}};
    PrepareFrame(&frame);
    return map.AddKeyframe(frame).id;
  };
  // In the new map's frame a camera's pose is [R | s t] for the truth [R | t] composed with
  // the similarity; as Rigid3d: cam_from_new = (Sim3(truth) * new_from_kept^-1) with t / scale.
  const auto in_new_frame = [&](const Rigid3d& cam_from_kept) {
    const Sim3d s = Sim3d(cam_from_kept) * new_from_kept.Inverse();
    return Rigid3d(s.rotation, s.translation / s.scale);
  };
  const Id kept0 = add_keyframe(truth[0], 0);
  add_keyframe(truth[1], 1);
  map.StartSegment();
  const Id query = add_keyframe(in_new_frame(truth[2]), 2);
  const Id other = add_keyframe(in_new_frame(truth[3]), 3);
  const Id point = map.AddLandmark(new_from_kept * point_in_kept, query).id;
  map.AddObservation(point, query, 0);
  map.AddObservation(point, other, 0);

  LoopDetection loop;
  loop.query_keyframe_id = query;
  loop.match_keyframe_id = kept0;
  // Kept world into the query camera, in the new map's units (2.5x).
  loop.corrected_query_cam_from_world =
      Sim3d(new_from_kept.scale, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) *
      Sim3d(truth[2]);
  ASSERT_TRUE(MergeSegmentsForLoop(&loop, &map));
  EXPECT_EQ(map.active_segment(), 0);
  EXPECT_EQ(map.NumKeyframesInSegment(0), 4);
  for (const auto& [id, k] : std::vector<std::pair<Id, int>>{{query, 2}, {other, 3}}) {
    const SlamKeyframe& kf = map.keyframes().at(id);
    EXPECT_LT((kf.cam_from_world.translation - truth[k].translation).norm(), 1e-9) << k;
    EXPECT_LT(kf.cam_from_world.rotation.angularDistance(truth[k].rotation), 1e-9) << k;
    EXPECT_NEAR(kf.scale, 1.0 / 2.5, 1e-12);
  }
  EXPECT_LT((map.landmarks().at(point).position_in_world - point_in_kept).norm(), 1e-9);
  // The detection now describes an identity correction at the merged pose.
  EXPECT_NEAR(loop.corrected_query_cam_from_world.scale, 1.0, 1e-12);
  EXPECT_LT((loop.corrected_query_cam_from_world.translation - truth[2].translation).norm(), 1e-9);
  // A loop within one segment is not a merge.
  EXPECT_FALSE(MergeSegmentsForLoop(&loop, &map));
}

}  // namespace
}  // namespace lcv::slam
