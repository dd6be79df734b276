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

// Runs the detector over the keyframes in insertion order; returns the first detection and the
// index of its query keyframe.
std::optional<LoopDetection> FirstDetection(const LoopScene& s, int* query_index) {
  LoopDetector detector;
  for (size_t k = 0; k < s.keyframe_ids.size(); ++k) {
    std::optional<LoopDetection> loop = detector.Detect(s.map, s.database, s.keyframe_ids[k], 11);
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

double AzimuthDeg(const Rigid3d& cam_from_world) {
  const Eigen::Vector3d c = cam_from_world.Center();
  return std::atan2(c.y(), c.x()) * 180.0 / M_PI;
}

TEST(LoopDetector, FindsTheRevisitWithTheMatchSideSim3) {
  const LoopSceneOptions options;
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  int query_index = -1;
  const std::optional<LoopDetection> loop = FirstDetection(*s, &query_index);
  ASSERT_TRUE(loop) << "seed " << options.seed;
  const int match_index = IndexOf(*s, loop->match_keyframe_id);
  ASSERT_GE(match_index, 0);
  // Revisit: the second lap starts at keyframe 40; the match is a first-lap keyframe nearby.
  EXPECT_GE(query_index, 40);
  EXPECT_LT(match_index, 10);
  double azimuth_gap = AzimuthDeg(s->true_cam_from_world[query_index]) -
                       AzimuthDeg(s->true_cam_from_world[match_index]);
  azimuth_gap = std::remainder(azimuth_gap, 360.0);
  EXPECT_LT(std::abs(azimuth_gap), 3 * options.step_deg);

  // Expected: the true pose with the query side's (planted) scale, x_cam = s (R X + t).
  const Sim3d& drift = s->drift[query_index];
  const Sim3d expected = Sim3d(drift.scale, Eigen::Quaterniond::Identity(),
                               Eigen::Vector3d::Zero()) *
                         Sim3d(s->true_cam_from_world[query_index]);
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

TEST(LoopDetector, NothingWithoutARevisit) {
  LoopSceneOptions options;
  options.num_keyframes = 34;  // 297 degrees: the last view does not reach the first one's wall
  const std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  int query_index = -1;
  EXPECT_FALSE(FirstDetection(*s, &query_index)) << "query " << query_index;
}

TEST(LoopDetector, SkipsTheFirstKeyframesAfterReset) {
  const std::unique_ptr<LoopScene> s = MakeLoopScene(LoopSceneOptions());
  LoopDetectorOptions options;
  options.min_keyframes_between_loops = 1000;
  LoopDetector detector(options);
  for (const Id id : s->keyframe_ids) EXPECT_FALSE(detector.Detect(s->map, s->database, id, 1));
}

}  // namespace
}  // namespace lcv::slam
