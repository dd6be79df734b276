#include "slam/data/slam_map.h"

#include <algorithm>
#include <vector>

#include <gtest/gtest.h>

#include "slam/data/local_map_snapshot.h"
#include "slam/geometry/sim3.h"
#include "slam/geometry/so3.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam {
namespace {

// Three frames seeing overlapping sets of points, linked into a SlamMap by ground truth.
class SlamMapTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = MakeCamera(testing::SyntheticPinhole());
    scene_ = testing::MakeSlabScene(600, -2.0, 3.0, 4.0, 8.0, 21);
    poses_ = testing::MakeLateralTrajectory(3, 0.3);
    std::mt19937_64 rng(22);
    testing::ObservationNoise noise;
    noise.clutter = 10;
    for (int f = 0; f < 3; ++f) {
      testing::SyntheticFrame s = testing::ObserveScene(scene_, *camera_, poses_[f], noise, &rng);
      Frame frame;
      frame.id = f;
      frame.camera = camera_.get();
      frame.keypoints = s.keypoints;
      frame.descriptors = s.descriptors;
      frame.cam_from_world = poses_[f];
      PrepareFrame(&frame);
      keyframe_ids_.push_back(map_.AddKeyframe(frame).id);
      point_index_.push_back(s.point_index);
    }
    // One landmark per scene point seen at least twice.
    std::map<int, Id> landmark_of_point;
    for (int f = 0; f < 3; ++f) {
      for (size_t i = 0; i < point_index_[f].size(); ++i) {
        const int j = point_index_[f][i];
        if (j < 0) continue;
        auto it = landmark_of_point.find(j);
        if (it == landmark_of_point.end()) {
          it = landmark_of_point
                   .emplace(j, map_.AddLandmark(scene_.points_in_world[j], keyframe_ids_[f]).id)
                   .first;
        }
        map_.AddObservation(it->second, keyframe_ids_[f], static_cast<int>(i));
      }
    }
    for (const auto& [j, id] : landmark_of_point) {
      if (map_.landmarks().at(id).NumObservations() < 2) {
        map_.EraseLandmark(id);
      } else {
        map_.UpdateLandmarkGeometry(id);
      }
    }
    for (const Id id : keyframe_ids_) map_.UpdateCovisibility(id);
  }

  std::unique_ptr<Camera> camera_;
  testing::SyntheticScene scene_;
  std::vector<Rigid3d> poses_;
  SlamMap map_;
  std::vector<Id> keyframe_ids_;
  std::vector<std::vector<int>> point_index_;
};

TEST_F(SlamMapTest, IdsAreUniqueMapWide) {
  std::set<Id> ids;
  for (const auto& [id, kf] : map_.keyframes()) EXPECT_TRUE(ids.insert(id).second);
  for (const auto& [id, lm] : map_.landmarks()) EXPECT_TRUE(ids.insert(id).second);
}

TEST_F(SlamMapTest, ObservationsAreSymmetric) {
  for (const auto& [id, landmark] : map_.landmarks()) {
    for (const Observation& o : landmark.observations) {
      EXPECT_EQ(map_.keyframes().at(o.keyframe_id).landmark_ids[o.keypoint_index], id);
    }
  }
  for (const auto& [id, kf] : map_.keyframes()) {
    for (size_t i = 0; i < kf.landmark_ids.size(); ++i) {
      if (kf.landmark_ids[i] == kInvalidId) continue;
      const SlamLandmark& lm = map_.landmarks().at(kf.landmark_ids[i]);
      bool found = false;
      for (const Observation& o : lm.observations) {
        found |= o.keyframe_id == id && o.keypoint_index == i;
      }
      EXPECT_TRUE(found);
    }
  }
}

TEST_F(SlamMapTest, CovisibilityCountsSharedLandmarks) {
  const SlamKeyframe& kf0 = map_.keyframes().at(keyframe_ids_[0]);
  ASSERT_TRUE(kf0.covisibility_weights.count(keyframe_ids_[1]));
  int shared = 0;
  for (const Id id : kf0.landmark_ids) {
    if (id == kInvalidId) continue;
    for (const Observation& o : map_.landmarks().at(id).observations) {
      shared += o.keyframe_id == keyframe_ids_[1];
    }
  }
  EXPECT_EQ(kf0.covisibility_weights.at(keyframe_ids_[1]), shared);
  EXPECT_EQ(map_.keyframes().at(keyframe_ids_[1]).covisibility_weights.at(keyframe_ids_[0]),
            shared);
  // Spanning tree: every keyframe but the first has an older parent.
  EXPECT_EQ(map_.keyframes().at(keyframe_ids_[1]).parent_id, keyframe_ids_[0]);
  EXPECT_NE(map_.keyframes().at(keyframe_ids_[2]).parent_id, kInvalidId);
}

TEST_F(SlamMapTest, LandmarkGeometry) {
  for (const auto& [id, lm] : map_.landmarks()) {
    EXPECT_NEAR(lm.mean_viewing_direction.norm(), 1.0, 1e-9);
    EXPECT_GT(lm.max_distance, lm.min_distance);
    const double d = (lm.position_in_world - map_.keyframes().at(lm.reference_keyframe_id).Center()).norm();
    EXPECT_NEAR(lm.max_distance, d, 1e-9);  // octave 0 everywhere
    // The descriptor is one of the observed ones.
    bool found = false;
    for (const Observation& o : lm.observations) {
      found |= map_.keyframes().at(o.keyframe_id).descriptors[o.keypoint_index] == lm.descriptor;
    }
    EXPECT_TRUE(found);
  }
}

TEST_F(SlamMapTest, EraseKeyframeKeepsMapConsistent) {
  const size_t before = map_.landmarks().size();
  map_.EraseKeyframe(keyframe_ids_[1]);
  EXPECT_EQ(map_.FindKeyframe(keyframe_ids_[1]), nullptr);
  EXPECT_LT(map_.landmarks().size(), before);  // points seen by 2 keyframes, one of them gone
  for (const auto& [id, lm] : map_.landmarks()) {
    EXPECT_GE(lm.NumObservations(), 2);
    for (const Observation& o : lm.observations) EXPECT_NE(o.keyframe_id, keyframe_ids_[1]);
  }
  EXPECT_EQ(map_.keyframes().at(keyframe_ids_[2]).parent_id, keyframe_ids_[0]);
  ASSERT_TRUE(map_.erased_keyframes().count(keyframe_ids_[1]));
  const auto& erased = map_.erased_keyframes().at(keyframe_ids_[1]);
  const Rigid3d reconstructed = erased.erased_from_anchor * map_.keyframes().at(erased.anchor_id).cam_from_world;
  EXPECT_LT((reconstructed.translation - poses_[1].translation).norm(), 1e-12);
  EXPECT_THROW(map_.EraseKeyframe(keyframe_ids_[0]), std::logic_error);
}

TEST_F(SlamMapTest, ReplaceLandmarkMergesObservations) {
  // Landmark a: seen by keyframes 0 and 1 only (its keyframe-2 observation removed). Landmark
  // b: a duplicate seen by keyframe 2 at a free keypoint.
  Id a = kInvalidId;
  for (const auto& [id, lm] : map_.landmarks()) {
    if (lm.NumObservations() == 3) {
      a = id;
      break;
    }
  }
  ASSERT_NE(a, kInvalidId);
  map_.RemoveObservation(a, keyframe_ids_[2], 2);
  ASSERT_EQ(map_.landmarks().at(a).NumObservations(), 2);
  const SlamKeyframe& kf2 = map_.keyframes().at(keyframe_ids_[2]);
  int free_keypoint = -1;
  for (size_t i = 0; i < kf2.landmark_ids.size(); ++i) {
    if (kf2.landmark_ids[i] == kInvalidId) free_keypoint = static_cast<int>(i);
  }
  ASSERT_GE(free_keypoint, 0);
  const Id b = map_.AddLandmark(map_.landmarks().at(a).position_in_world, keyframe_ids_[2]).id;
  ASSERT_TRUE(map_.AddObservation(b, keyframe_ids_[2], free_keypoint));
  const int before = map_.landmarks().at(a).NumObservations();
  map_.ReplaceLandmark(b, a);
  EXPECT_EQ(map_.FindLandmark(b), nullptr);
  EXPECT_EQ(map_.landmarks().at(a).NumObservations(), before + 1);
  EXPECT_EQ(kf2.landmark_ids[free_keypoint], a);
  // A second observation by the same keyframe is refused.
  EXPECT_FALSE(map_.AddObservation(a, keyframe_ids_[2], free_keypoint == 0 ? 1 : 0));
}

TEST_F(SlamMapTest, TransformScalesEverything) {
  const Eigen::Vector3d c2 = map_.keyframes().at(keyframe_ids_[2]).Center();
  const SlamLandmark first = map_.landmarks().begin()->second;
  map_.Transform(0.5);
  EXPECT_LT((map_.keyframes().at(keyframe_ids_[2]).Center() - 0.5 * c2).norm(), 1e-12);
  const SlamLandmark& after = map_.landmarks().begin()->second;
  EXPECT_LT((after.position_in_world - 0.5 * first.position_in_world).norm(), 1e-12);
  EXPECT_NEAR(after.max_distance, 0.5 * first.max_distance, 1e-12);
}

TEST_F(SlamMapTest, ToMapAndSnapshot) {
  const Map map = map_.ToMap(testing::SyntheticPinhole(), 0);
  EXPECT_EQ(map.keyframes.size(), 3u);
  EXPECT_EQ(map.points.size(), map_.landmarks().size());
  EXPECT_LT(map.NextFreeId() - 1, map_.NewId());

  const LocalMapSnapshot snapshot =
      MakeLocalMapSnapshot(map_, keyframe_ids_[2], LocalMapSnapshotOptions(), 7);
  EXPECT_EQ(snapshot.version, 7u);
  EXPECT_EQ(snapshot.keyframes.size(), 3u);
  EXPECT_EQ(snapshot.landmarks.size(), map_.landmarks().size());
  for (const auto& [id, lm] : map_.landmarks()) {
    const SnapshotLandmark* s = snapshot.FindLandmark(id);
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->position_in_world, lm.position_in_world);
  }
  EXPECT_EQ(snapshot.FindLandmark(kInvalidId - 1), nullptr);
  EXPECT_NE(snapshot.FindKeyframe(keyframe_ids_[0]), nullptr);
  EXPECT_GT(snapshot.reference_num_tracked, 0);
  // The keyframe policy's scene distance: the median over the reference keyframe's landmarks.
  const SlamKeyframe& reference = map_.keyframes().at(keyframe_ids_[2]);
  std::vector<double> distances;
  for (const Id id : reference.landmark_ids) {
    if (id == kInvalidId) continue;
    distances.push_back((map_.landmarks().at(id).position_in_world - reference.Center()).norm());
  }
  ASSERT_FALSE(distances.empty());
  std::sort(distances.begin(), distances.end());
  EXPECT_DOUBLE_EQ(snapshot.reference_median_distance, distances[distances.size() / 2]);
}

// Segments: a second map started after the first was lost lives beside it, in its own frame.
TEST_F(SlamMapTest, SegmentsKeepKeyframesApartUntilMoved) {
  const size_t keyframes_before = map_.keyframes().size();
  const size_t landmarks_before = map_.landmarks().size();
  EXPECT_EQ(map_.active_segment(), 0);
  const Id first_of_segment0 = map_.first_keyframe_id();
  const int segment = map_.StartSegment();
  EXPECT_EQ(segment, 1);
  EXPECT_EQ(map_.first_keyframe_id(), kInvalidId);

  // The second map: the same views in a frame 3x larger, rotated and shifted.
  const Sim3d second_from_first(3.0, Eigen::Quaterniond(ExpSO3(Eigen::Vector3d(0.1, -0.4, 0.2))),
                                Eigen::Vector3d(5.0, -1.0, 2.0));
  std::vector<Id> second_ids;
  for (int f = 0; f < 2; ++f) {
    Frame frame;
    frame.id = 10 + f;
    frame.camera = camera_.get();
    const Sim3d moved = Sim3d(poses_[f]) * second_from_first.Inverse();
    frame.cam_from_world = Rigid3d(moved.rotation, moved.translation / moved.scale);
    frame.keypoints = {Keypoint{320.f, 240.f, 0.f, 0}};
    frame.descriptors = {OrbDescriptor{}};
    PrepareFrame(&frame);
    second_ids.push_back(map_.AddKeyframe(frame).id);
  }
  const Id point = map_.AddLandmark(second_from_first * Eigen::Vector3d(0.5, 0.2, 6.0),
                                    second_ids[0]).id;
  map_.AddObservation(point, second_ids[0], 0);
  map_.AddObservation(point, second_ids[1], 0);
  EXPECT_EQ(map_.keyframes().at(second_ids[0]).segment, 1);
  EXPECT_EQ(map_.landmarks().at(point).segment, 1);
  EXPECT_EQ(map_.first_keyframe_id(), second_ids[0]);
  EXPECT_EQ(map_.NumKeyframesInSegment(0), static_cast<int>(keyframes_before));
  EXPECT_EQ(map_.NumKeyframesInSegment(1), 2);
  // The persistent model is the active segment's.
  const Map exported = map_.ToMap(testing::SyntheticPinhole());
  EXPECT_EQ(exported.keyframes.size(), 2u);
  EXPECT_EQ(exported.points.size(), 1u);

  // Merge: segment 1 moved into segment 0's frame lands on the first map's poses.
  map_.MoveSegment(1, 0, second_from_first.Inverse());
  EXPECT_EQ(map_.active_segment(), 0);
  EXPECT_EQ(map_.first_keyframe_id(), first_of_segment0);
  EXPECT_EQ(map_.NumKeyframesInSegment(0), static_cast<int>(keyframes_before) + 2);
  for (int f = 0; f < 2; ++f) {
    const SlamKeyframe& kf = map_.keyframes().at(second_ids[f]);
    EXPECT_LT((kf.cam_from_world.translation - poses_[f].translation).norm(), 1e-9);
    EXPECT_LT(kf.cam_from_world.rotation.angularDistance(poses_[f].rotation), 1e-9);
    EXPECT_NEAR(kf.scale, 1.0 / 3.0, 1e-12);  // lengths there shrank 3x
  }
  EXPECT_LT((map_.landmarks().at(point).position_in_world - Eigen::Vector3d(0.5, 0.2, 6.0)).norm(),
            1e-9);
  EXPECT_EQ(map_.landmarks().at(point).segment, 0);
  EXPECT_EQ(map_.ToMap(testing::SyntheticPinhole()).keyframes.size(), keyframes_before + 2);

  // Erasing a segment removes exactly its keyframes and landmarks.
  map_.StartSegment();
  Frame frame;
  frame.id = 20;
  frame.camera = camera_.get();
  PrepareFrame(&frame);
  map_.AddKeyframe(frame);
  map_.EraseSegment(map_.active_segment());
  EXPECT_EQ(map_.keyframes().size(), keyframes_before + 2);
  EXPECT_EQ(map_.landmarks().size(), landmarks_before + 1);
}

// Segments registered in a line cloud stay known as such after a new segment starts (System keeps
// them and joins their frames to the trajectories); a move into another segment's frame or an
// erase ends it.
TEST_F(SlamMapTest, RegisteredSegmentsStayInTheLineCloudFrameUntilMovedOrErased) {
  EXPECT_FALSE(map_.SegmentInLineCloudFrame(0));
  map_.SetRegisteredSegment(0);
  EXPECT_TRUE(map_.ActiveSegmentRegistered());
  const int second = map_.StartSegment();
  EXPECT_FALSE(map_.ActiveSegmentRegistered());
  EXPECT_TRUE(map_.SegmentInLineCloudFrame(0));
  EXPECT_FALSE(map_.SegmentInLineCloudFrame(second));
  map_.SetRegisteredSegment(second);
  EXPECT_TRUE(map_.SegmentInLineCloudFrame(0));
  EXPECT_TRUE(map_.SegmentInLineCloudFrame(second));
  EXPECT_EQ(map_.registered_segment(), second);

  const int third = map_.StartSegment();
  map_.SetRegisteredSegment(third);
  map_.MoveSegment(second, third, Sim3d());  // a merge: second's keyframes are third's now
  EXPECT_FALSE(map_.SegmentInLineCloudFrame(second));
  EXPECT_TRUE(map_.SegmentInLineCloudFrame(third));
  map_.EraseSegment(0);
  EXPECT_FALSE(map_.SegmentInLineCloudFrame(0));
  map_.ClearClientData();
  EXPECT_FALSE(map_.SegmentInLineCloudFrame(third));
}

}  // namespace
}  // namespace lcv::slam
