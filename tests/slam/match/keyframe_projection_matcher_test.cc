#include "slam/match/keyframe_projection_matcher.h"

#include <map>

#include <gtest/gtest.h>

#include "tests/slam/match/matcher_test_util.h"

namespace lcv::slam {
namespace {

// Two keyframes linked to their scene points by ground truth, and a third one (`target`) with
// its keypoints but no links: the landmarks are matched into it by projection.
class KeyframeProjectionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = MakeCamera(testing::SyntheticPinhole());
    scene_ = testing::MakeSlabScene(500, -2.0, 3.0, 4.0, 8.0, 41);
    poses_ = testing::MakeLateralTrajectory(3, 0.25);
    std::mt19937_64 rng(42);
    testing::ObservationNoise noise;
    noise.clutter = 40;
    std::vector<Id> ids;
    for (int f = 0; f < 3; ++f) {
      observed_.push_back(testing::ObserveScene(scene_, *camera_, poses_[f], noise, &rng));
      ids.push_back(map_.AddKeyframe(testing::MakeFrame(*camera_, observed_[f], poses_[f], f)).id);
    }
    target_ = ids[2];
    std::map<int, Id> landmark_of_point;
    for (int f = 0; f < 2; ++f) {
      for (size_t i = 0; i < observed_[f].point_index.size(); ++i) {
        const int j = observed_[f].point_index[i];
        if (j < 0) continue;
        auto it = landmark_of_point.find(j);
        if (it == landmark_of_point.end()) {
          const Id id = map_.AddLandmark(scene_.points_in_world[j], ids[f]).id;
          it = landmark_of_point.emplace(j, id).first;
          point_of_landmark_[id] = j;
        }
        map_.AddObservation(it->second, ids[f], static_cast<int>(i));
      }
    }
    for (const auto& [j, id] : landmark_of_point) {
      map_.UpdateLandmarkGeometry(id);
      landmarks_.push_back(id);
    }
  }

  const SlamKeyframe& target() const { return map_.keyframes().at(target_); }
  int Right(const std::vector<KeyframeProjectionMatch>& matches) const {
    int right = 0;
    for (const KeyframeProjectionMatch& m : matches) {
      right += observed_[2].point_index[m.keypoint_index] == point_of_landmark_.at(m.landmark_id);
    }
    return right;
  }

  std::unique_ptr<Camera> camera_;
  testing::SyntheticScene scene_;
  std::vector<Rigid3d> poses_;
  std::vector<testing::SyntheticFrame> observed_;
  SlamMap map_;
  Id target_ = kInvalidId;
  std::vector<Id> landmarks_;
  std::map<Id, int> point_of_landmark_;
};

TEST_F(KeyframeProjectionTest, MatchesTheVisibleLandmarksAndOnlyOncePerKeypoint) {
  const std::vector<KeyframeProjectionMatch> matches = MatchLandmarksIntoKeyframe(
      map_, target(), Sim3d(poses_[2]), landmarks_, KeyframeProjectionOptions());
  int visible = 0;
  for (const int j : observed_[2].point_index) {
    if (j < 0) continue;
    for (const auto& [id, point] : point_of_landmark_) visible += point == j;
  }
  ASSERT_GT(visible, 100);
  EXPECT_GE(static_cast<int>(matches.size()), 0.9 * visible) << matches.size() << " of " << visible;
  EXPECT_GE(Right(matches), static_cast<int>(matches.size()) - 2);
  for (size_t k = 1; k < matches.size(); ++k) {
    EXPECT_LT(matches[k - 1].keypoint_index, matches[k].keypoint_index);
  }
}

TEST_F(KeyframeProjectionTest, ScaleOfTheSimilarityPoseDoesNotChangeTheResult) {
  const std::vector<KeyframeProjectionMatch> rigid = MatchLandmarksIntoKeyframe(
      map_, target(), Sim3d(poses_[2]), landmarks_, KeyframeProjectionOptions());
  const Sim3d scaled = Sim3d(2.5, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) *
                       Sim3d(poses_[2]);
  const std::vector<KeyframeProjectionMatch> similarity = MatchLandmarksIntoKeyframe(
      map_, target(), scaled, landmarks_, KeyframeProjectionOptions());
  ASSERT_EQ(rigid.size(), similarity.size());
  for (size_t k = 0; k < rigid.size(); ++k) {
    EXPECT_EQ(rigid[k].keypoint_index, similarity[k].keypoint_index);
    EXPECT_EQ(rigid[k].landmark_id, similarity[k].landmark_id);
  }
}

TEST_F(KeyframeProjectionTest, SkipsBlockedKeypointsSeenLandmarksAndOutOfRangeDistances) {
  const std::vector<KeyframeProjectionMatch> all = MatchLandmarksIntoKeyframe(
      map_, target(), Sim3d(poses_[2]), landmarks_, KeyframeProjectionOptions());
  ASSERT_GE(all.size(), 3u);
  // Block the first match's keypoint, link the second's landmark to the target, and shrink the
  // third's scale-invariance range far below its distance.
  std::vector<char> blocked(target().keypoints.size(), 0);
  blocked[all[0].keypoint_index] = 1;
  map_.AddObservation(all[1].landmark_id, target_, all[1].keypoint_index);
  SlamLandmark* far = map_.FindLandmark(all[2].landmark_id);
  far->min_distance = 0.1;
  far->max_distance = 0.2;
  const std::vector<KeyframeProjectionMatch> again = MatchLandmarksIntoKeyframe(
      map_, target(), Sim3d(poses_[2]), landmarks_, KeyframeProjectionOptions(), &blocked);
  for (const KeyframeProjectionMatch& m : again) {
    EXPECT_NE(m.keypoint_index, all[0].keypoint_index);
    EXPECT_NE(m.landmark_id, all[1].landmark_id);
    EXPECT_NE(m.landmark_id, all[2].landmark_id);
  }
  EXPECT_GE(again.size() + 3, all.size());
}

}  // namespace
}  // namespace lcv::slam
