#include "slam/module/loop_detector.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "tests/slam/module/loop_scene.h"

namespace lcv::slam {
namespace {

using testing::LoopScene;
using testing::LoopSceneOptions;
using testing::MakeLoopScene;

// Runs the detector over the keyframes in insertion order, as System does: each keyframe enters
// the database just before its query, so later keyframes are never candidates. Returns the first
// detection and the index of its query keyframe.
std::optional<LoopDetection> FirstDetection(const LoopScene& s, int* query_index,
                                            LoopDetectionAttempt* attempt = nullptr) {
  LoopDetector detector;
  BowDatabase database;
  for (size_t k = 0; k < s.keyframe_ids.size(); ++k) {
    const Id id = s.keyframe_ids[k];
    database.Add(id, s.map.keyframes().at(id).bow);
    std::optional<LoopDetection> loop = detector.Detect(s.map, database, id, 11);
    if (attempt != nullptr) *attempt = detector.last_attempt();
    if (loop) {
      *query_index = static_cast<int>(k);
      return loop;
    }
  }
  return std::nullopt;
}

int IndexOf(const LoopScene& s, Id keyframe_id) {
  for (size_t k = 0; k < s.keyframe_ids.size(); ++k) {
    if (s.keyframe_ids[k] == keyframe_id) return static_cast<int>(k);
  }
  return -1;
}

// The query's true pose seen from the match side's world (world_match = D_match * world_true),
// at the query side's scale: x_cam = s_query (R X_true + t), X_true = D_match^-1 X_match.
Sim3d ExpectedCorrection(const LoopScene& s, int query_index, int match_index) {
  return Sim3d(s.drift[query_index].scale, Eigen::Quaterniond::Identity(),
               Eigen::Vector3d::Zero()) *
         Sim3d(s.true_cam_from_world[query_index]) * s.drift[match_index].Inverse();
}

double AzimuthDeg(const Rigid3d& cam_from_world) {
  const Eigen::Vector3d c = cam_from_world.Center();
  return std::atan2(c.y(), c.x()) * 180.0 / M_PI;
}

TEST(LoopDetector, FindsTheRevisitWithTheMatchSideSim3) {
  const LoopSceneOptions options;
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  int query_index = -1;
  LoopDetectionAttempt attempt;
  const std::optional<LoopDetection> loop = FirstDetection(*s, &query_index, &attempt);
  ASSERT_TRUE(loop) << "seed " << options.seed;
  const int match_index = IndexOf(*s, loop->match_keyframe_id);
  ASSERT_GE(match_index, 0);
  EXPECT_TRUE(attempt.detected);
  EXPECT_EQ(attempt.best_candidate_id, loop->match_keyframe_id);
  EXPECT_GE(attempt.num_bow_matches, attempt.num_ransac_inliers);
  EXPECT_EQ(attempt.num_refined_inliers, loop->num_inliers);
  EXPECT_EQ(attempt.num_total_matches, static_cast<int>(loop->matches.size()));
  // Revisit: the second lap starts at keyframe 40; the match is a first-lap keyframe nearby.
  EXPECT_GE(query_index, 40);
  EXPECT_LT(match_index, 10);
  double azimuth_gap = AzimuthDeg(s->true_cam_from_world[query_index]) -
                       AzimuthDeg(s->true_cam_from_world[match_index]);
  azimuth_gap = std::remainder(azimuth_gap, 360.0);
  EXPECT_LT(std::abs(azimuth_gap), 3 * options.step_deg);

  // Expected: the true pose with the query side's (planted) scale, x_cam = s (R X + t), from the
  // match side's world (undrifted here).
  const Sim3d& drift = s->drift[query_index];
  const Sim3d expected = ExpectedCorrection(*s, query_index, match_index);
  const Sim3d& got = loop->corrected_query_cam_from_world;
  const double rotation_error_deg =
      AngularDistance(got.rotation, expected.rotation) * 180.0 / M_PI;
  const Eigen::Vector3d got_center = -(got.rotation.conjugate() * got.translation) / got.scale;
  const double center_error_m =
      (got_center - s->true_cam_from_world[query_index].Center()).norm();
  const double scale_error = std::abs(got.scale / drift.scale - 1.0);
  std::printf("query %d match %d: %zu matches, %d Sim3 inliers; rotation %.3f deg, centre %.3f m, "
              "scale %.4f (planted %.4f)\n",
              query_index, match_index, loop->matches.size(), loop->num_inliers,
              rotation_error_deg, center_error_m, got.scale, drift.scale);
  EXPECT_LT(rotation_error_deg, 0.3);
  EXPECT_LT(center_error_m, 0.05);
  EXPECT_LT(scale_error, 0.01);
  EXPECT_GE(static_cast<int>(loop->matches.size()), 40);

  // The matches link the query's keypoints to landmarks of the same scene point.
  int right = 0;
  for (const auto& [index, landmark_id] : loop->matches) {
    right += s->point_of_keypoint[query_index][index] == s->point_of_landmark.at(landmark_id);
  }
  EXPECT_GE(right, 0.95 * loop->matches.size()) << right << " of " << loop->matches.size();
}

// The same with wider cameras: more of the ring in view, more covisibility.
class LoopDetectorCameras : public ::testing::TestWithParam<int> {};

TEST_P(LoopDetectorCameras, FindsTheRevisit) {
  LoopSceneOptions options;
  options.camera = GetParam() == 0 ? testing::RingFisheye() : testing::RingEquirectangular();
  options.num_points = 2000;
  // A point stays in these views for 10-20 keyframes, so the query's landmarks were made up to
  // 20 keyframes earlier: the drift ramp ends early enough for them all to share the final drift.
  options.drift_start = 2;
  options.drift_end = 10;
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  int query_index = -1;
  const std::optional<LoopDetection> loop = FirstDetection(*s, &query_index);
  ASSERT_TRUE(loop) << "seed " << options.seed;
  const int match_index = IndexOf(*s, loop->match_keyframe_id);
  const Sim3d& got = loop->corrected_query_cam_from_world;
  const Sim3d expected = ExpectedCorrection(*s, query_index, match_index);
  const Eigen::Vector3d got_center = -(got.rotation.conjugate() * got.translation) / got.scale;
  const Eigen::Vector3d expected_center =
      -(expected.rotation.conjugate() * expected.translation) / expected.scale;
  const double center_error_m = (got_center - expected_center).norm();
  const double rotation_error_deg = AngularDistance(got.rotation, expected.rotation) * 180.0 / M_PI;
  std::printf("query %d match %d: %zu matches; rotation %.3f deg, centre %.3f m, scale %.4f "
              "(planted %.4f)\n",
              query_index, match_index, loop->matches.size(), rotation_error_deg, center_error_m,
              got.scale, expected.scale);
  EXPECT_GE(query_index, 28);  // the wide views reach the first keyframes' wall earlier
  EXPECT_LT(match_index, 10);
  // These cameras resolve ~0.25 degrees per pixel (5x coarser than the pinhole) and the shared
  // wall is seen over a narrow depth range, where rotation and translation trade off: measured
  // 0.13 / 0.33 degrees and 0.016 / 0.044 m (fisheye / equirectangular).
  EXPECT_LT(rotation_error_deg, 0.6);
  EXPECT_LT(center_error_m, 0.1);
  EXPECT_LT(std::abs(got.scale / expected.scale - 1.0), 0.01);
  int right = 0;
  for (const auto& [index, landmark_id] : loop->matches) {
    right += s->point_of_keypoint[query_index][index] == s->point_of_landmark.at(landmark_id);
  }
  EXPECT_GE(right, 0.95 * loop->matches.size()) << right << " of " << loop->matches.size();
}

INSTANTIATE_TEST_SUITE_P(FisheyeAndEquirectangular, LoopDetectorCameras, ::testing::Values(0, 1));

TEST(LoopDetector, NothingWithoutARevisit) {
  LoopSceneOptions options;
  options.num_keyframes = 34;  // 297 degrees: the last view does not reach the first one's wall
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  int query_index = -1;
  LoopDetectionAttempt attempt;
  EXPECT_FALSE(FirstDetection(*s, &query_index, &attempt)) << "query " << query_index;
  EXPECT_FALSE(attempt.detected);
  EXPECT_FALSE(attempt.skipped);
}

TEST(LoopDetector, SkipsTheFirstKeyframesAfterReset) {
  const std::unique_ptr<LoopScene> s = MakeLoopScene(LoopSceneOptions());
  LoopDetectorOptions options;
  options.min_keyframes_between_loops = 1000;
  LoopDetector detector(options);
  for (const Id id : s->keyframe_ids) {
    EXPECT_FALSE(detector.Detect(s->map, s->database, id, 1));
    EXPECT_TRUE(detector.last_attempt().skipped);
  }
}

}  // namespace
}  // namespace lcv::slam
