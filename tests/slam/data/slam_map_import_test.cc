#include "slam/data/slam_map_import.h"

#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "mapping/io/map_file.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam {
namespace {

constexpr int kNumFrames = 8;

// A SlamMap built the way local mapping builds one: keyframes in order, each linked to the
// landmarks it sees (a landmark per scene point seen by >= 2 frames, created by the keyframe that
// sees it second and linked to it first, as triangulation does), covisibility updated on
// insertion. One landmark is erased afterwards so the ids have
// a gap. Octaves vary so the scale-invariance distances depend on the reference keyframe.
class SlamMapImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    params_ = testing::SyntheticPinhole();
    camera_ = MakeCamera(params_);
    const testing::SyntheticScene scene = testing::MakeSlabScene(700, -2.0, 4.5, 4.0, 9.0, 31);
    const std::vector<Rigid3d> poses = testing::MakeLateralTrajectory(kNumFrames, 0.3);
    std::mt19937_64 rng(32);
    std::uniform_int_distribution<int> octave(0, 3);
    testing::ObservationNoise noise;
    noise.clutter = 20;
    std::vector<testing::SyntheticFrame> frames;
    std::map<int, int> sightings;
    for (int f = 0; f < kNumFrames; ++f) {
      frames.push_back(testing::ObserveScene(scene, *camera_, poses[f], noise, &rng));
      for (Keypoint& kp : frames.back().keypoints) kp.octave = octave(rng);
      for (const int j : frames.back().point_index) {
        if (j >= 0) ++sightings[j];
      }
    }
    std::map<int, Id> landmark_of_point;
    std::map<int, std::pair<Id, int>> first_sighting;  // scene point -> (keyframe, keypoint)
    for (int f = 0; f < kNumFrames; ++f) {
      Frame frame;
      frame.id = f;
      frame.timestamp = 0.1 * f;
      frame.camera = camera_.get();
      frame.keypoints = frames[f].keypoints;
      frame.descriptors = frames[f].descriptors;
      frame.cam_from_world = poses[f];
      PrepareFrame(&frame);
      const Id kf = original_.AddKeyframe(frame).id;
      for (size_t i = 0; i < frames[f].point_index.size(); ++i) {
        const int j = frames[f].point_index[i];
        if (j < 0 || sightings[j] < 2) continue;
        const auto it = landmark_of_point.find(j);
        if (it != landmark_of_point.end()) {
          original_.AddObservation(it->second, kf, static_cast<int>(i));
        } else if (!first_sighting.count(j)) {
          first_sighting[j] = {kf, static_cast<int>(i)};
        } else {
          // As local mapping triangulates: the new keyframe creates the point and is linked
          // first, so the first observation is not the oldest keyframe's.
          const Id id = original_.AddLandmark(scene.points_in_world[j], kf).id;
          original_.AddObservation(id, kf, static_cast<int>(i));
          original_.AddObservation(id, first_sighting[j].first, first_sighting[j].second);
          landmark_of_point[j] = id;
        }
      }
      for (const auto& [j, id] : landmark_of_point) original_.UpdateLandmarkGeometry(id);
      original_.UpdateCovisibility(kf);
    }
    const Id erased = landmark_of_point.begin()->second;
    original_.EraseLandmark(erased);
    for (auto& [id, kf] : original_.mutable_keyframes()) original_.UpdateCovisibility(id);
  }

  CameraParams params_;
  std::unique_ptr<Camera> camera_;
  SlamMap original_;
};

TEST_F(SlamMapImportTest, RoundTripThroughFileBytesPreservesTheMap) {
  // The original is not trivial: every keyframe has covisible neighbours and a parent.
  for (const auto& [id, kf] : original_.keyframes()) {
    EXPECT_FALSE(kf.ordered_covisibles.empty()) << "keyframe " << id;
    if (id != original_.first_keyframe_id()) {
      EXPECT_NE(kf.parent_id, kInvalidId) << "keyframe " << id;
    }
  }
  const Map saved = original_.ToMap(params_, 0);
  const Map loaded = mapping::ParseMap(mapping::SerializeMap(saved, mapping::MapEncoding::kMessagePack),
                                       "round_trip.lcmap");
  SlamMap imported = ImportSlamMap(loaded, *camera_, ScaleLevels());

  EXPECT_EQ(imported.first_keyframe_id(), original_.first_keyframe_id());
  ASSERT_EQ(imported.keyframes().size(), original_.keyframes().size());
  ASSERT_EQ(imported.landmarks().size(), original_.landmarks().size());
  for (const auto& [id, kf] : original_.keyframes()) {
    SCOPED_TRACE(::testing::Message() << "keyframe " << id);
    const SlamKeyframe* out = imported.FindKeyframe(id);
    ASSERT_NE(out, nullptr);
    EXPECT_EQ(out->id, id);
    EXPECT_EQ(out->camera, camera_.get());
    EXPECT_EQ(out->timestamp, kf.timestamp);
    EXPECT_LT((out->cam_from_world.translation - kf.cam_from_world.translation).norm(), 1e-12);
    EXPECT_LT(out->cam_from_world.rotation.angularDistance(kf.cam_from_world.rotation), 1e-12);
    ASSERT_EQ(out->keypoints.size(), kf.keypoints.size());
    EXPECT_EQ(out->descriptors, kf.descriptors);
    EXPECT_EQ(out->landmark_ids, kf.landmark_ids);
    for (size_t i = 0; i < kf.keypoints.size(); ++i) {
      EXPECT_EQ(out->keypoints[i].x, kf.keypoints[i].x);
      EXPECT_EQ(out->keypoints[i].octave, kf.keypoints[i].octave);
      EXPECT_LT((out->bearings[i] - kf.bearings[i]).norm(), 1e-12);
    }
    EXPECT_EQ(out->covisibility_weights, kf.covisibility_weights);
    EXPECT_EQ(out->ordered_covisibles, kf.ordered_covisibles);
    EXPECT_EQ(out->parent_id, kf.parent_id);
    EXPECT_EQ(std::set<Id>(out->child_ids.begin(), out->child_ids.end()),
              std::set<Id>(kf.child_ids.begin(), kf.child_ids.end()));
    // The grid answers like the original's.
    std::vector<int> a, b;
    kf.grid.Query(kf.keypoints, 320.f, 240.f, 60.f, 0, -1, &a);
    out->grid.Query(out->keypoints, 320.f, 240.f, 60.f, 0, -1, &b);
    EXPECT_EQ(a, b);
  }
  for (const auto& [id, lm] : original_.landmarks()) {
    SCOPED_TRACE(::testing::Message() << "landmark " << id);
    const SlamLandmark* out = imported.FindLandmark(id);
    ASSERT_NE(out, nullptr);
    EXPECT_EQ(out->position_in_world, lm.position_in_world);
    EXPECT_EQ(out->descriptor, lm.descriptor);
    ASSERT_EQ(out->observations.size(), lm.observations.size());
    for (size_t k = 0; k < lm.observations.size(); ++k) {
      EXPECT_EQ(out->observations[k].keyframe_id, lm.observations[k].keyframe_id);
      EXPECT_EQ(out->observations[k].keypoint_index, lm.observations[k].keypoint_index);
    }
    EXPECT_EQ(out->first_keyframe_id, lm.first_keyframe_id);
    EXPECT_EQ(out->reference_keyframe_id, lm.reference_keyframe_id);
    EXPECT_LT((out->mean_viewing_direction - lm.mean_viewing_direction).norm(), 1e-12);
    EXPECT_NEAR(out->max_distance, lm.max_distance, 1e-12);
    EXPECT_NEAR(out->min_distance, lm.min_distance, 1e-12);
  }
  // New ids continue after the file's.
  EXPECT_GE(imported.NewId(), loaded.NextFreeId());
  // And the imported map saves to the same file.
  EXPECT_EQ(mapping::SerializeMap(imported.ToMap(params_, 0), mapping::MapEncoding::kJson),
            mapping::SerializeMap(saved, mapping::MapEncoding::kJson));
}

// RebuildCovisibility (one pass, used by the import) against UpdateCovisibility on every
// keyframe in id order, on maps with dense and with sparse covisibility (keyframes sharing fewer
// than kCovisibilityThreshold landmarks keep only their strongest link).
TEST_F(SlamMapImportTest, LoopEdgesSurviveTheFile) {
  SlamMap with_loop = original_;
  const Id first = with_loop.keyframes().begin()->first;
  const Id last = with_loop.keyframes().rbegin()->first;
  ASSERT_NE(first, last);
  with_loop.AddLoopEdge(last, first);
  const Map saved = with_loop.ToMap(params_, 0);
  ASSERT_EQ(saved.loop_edges.size(), 1u);
  const Map loaded = mapping::ParseMap(
      mapping::SerializeMap(saved, mapping::MapEncoding::kJson), "loop.json");
  const SlamMap imported = ImportSlamMap(loaded, *camera_, ScaleLevels());
  ASSERT_EQ(imported.loop_edges().size(), 1u);
  EXPECT_EQ(imported.loop_edges()[0], std::make_pair(last, first));
  EXPECT_TRUE(imported.HasLoopEdge(first));
  EXPECT_TRUE(imported.HasLoopEdge(last));
}

TEST(RebuildCovisibility, EqualsUpdateCovisibilityInIdOrder) {
  const CameraParams params = testing::SyntheticPinhole();
  const std::unique_ptr<Camera> camera = MakeCamera(params);
  for (const int num_points : {1500, 120, 40}) {
    SCOPED_TRACE(::testing::Message() << num_points << " points");
    const testing::SyntheticScene scene = testing::MakeSlabScene(num_points, -2, 14, 4, 8, 5);
    const std::vector<Rigid3d> poses = testing::MakeLateralTrajectory(12, 1.0);
    std::mt19937_64 rng(6);
    Map map;
    map.cameras[0] = params;
    std::map<int, std::vector<Observation>> observations;
    for (int k = 0; k < 12; ++k) {
      const testing::SyntheticFrame s =
          testing::ObserveScene(scene, *camera, poses[k], testing::ObservationNoise(), &rng);
      Keyframe kf;
      kf.id = 1 + k;
      kf.camera_id = 0;
      kf.cam_from_world = poses[k];
      kf.keypoints = s.keypoints;
      kf.descriptors = s.descriptors;
      for (std::size_t i = 0; i < s.point_index.size(); ++i) {
        if (s.point_index[i] >= 0) {
          observations[s.point_index[i]].push_back({kf.id, static_cast<std::uint32_t>(i)});
        }
      }
      map.keyframes[kf.id] = kf;
    }
    for (const auto& [j, obs] : observations) {
      map.points[100 + j] = PointLandmark{100 + static_cast<Id>(j), scene.points_in_world[j],
                                          Eigen::Matrix3d::Identity(), std::nullopt, obs};
    }
    const SlamMap rebuilt = ImportSlamMap(map, *camera, ScaleLevels());
    SlamMap sequential = rebuilt;
    for (auto& [id, kf] : sequential.mutable_keyframes()) {
      kf.covisibility_weights.clear();
      kf.ordered_covisibles.clear();
      kf.parent_id = kInvalidId;
      kf.child_ids.clear();
    }
    for (const auto& [id, kf] : map.keyframes) sequential.UpdateCovisibility(id);
    int weak = 0;
    for (const auto& [id, kf] : sequential.keyframes()) {
      SCOPED_TRACE(::testing::Message() << "keyframe " << id);
      const SlamKeyframe& other = rebuilt.keyframes().at(id);
      EXPECT_EQ(other.covisibility_weights, kf.covisibility_weights);
      EXPECT_EQ(other.ordered_covisibles, kf.ordered_covisibles);
      EXPECT_EQ(other.parent_id, kf.parent_id);
      EXPECT_EQ(other.child_ids, kf.child_ids);
      for (const auto& [neighbour, weight] : kf.covisibility_weights) {
        weak += weight < SlamMap::kCovisibilityThreshold;
      }
    }
    if (num_points == 40) {
      EXPECT_GT(weak, 0) << "the sparse case has no weak links";
    }
  }
}

TEST_F(SlamMapImportTest, ForeignMapDetails) {
  Map map = original_.ToMap(params_, 0);
  // A point without stored descriptor gets the representative one; a point without
  // observations is skipped; the smallest keyframe id anchors the map; ids continue after the
  // largest one.
  PointLandmark& first_point = map.points.begin()->second;
  const Id no_descriptor = first_point.id;
  const OrbDescriptor representative = original_.landmarks().at(no_descriptor).descriptor;
  first_point.descriptor.reset();
  PointLandmark lonely;
  lonely.id = 100000;
  map.points[lonely.id] = lonely;
  const SlamMap imported = ImportSlamMap(map, *camera_, ScaleLevels());
  EXPECT_EQ(imported.landmarks().at(no_descriptor).descriptor, representative);
  EXPECT_EQ(imported.FindLandmark(lonely.id), nullptr);
  EXPECT_EQ(imported.first_keyframe_id(), map.keyframes.begin()->first);
  SlamMap copy = imported;
  EXPECT_EQ(copy.NewId(), 100001u);
}

// Expects ImportSlamMap to throw std::invalid_argument whose message contains `fragment`.
void ExpectRejected(const Map& map, const Camera& camera, const std::string& fragment) {
  try {
    ImportSlamMap(map, camera, ScaleLevels());
    ADD_FAILURE() << "accepted; expected an error containing \"" << fragment << "\"";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST_F(SlamMapImportTest, RejectsMissingDescriptors) {
  Map map = original_.ToMap(params_, 0);
  auto it = std::next(map.keyframes.begin(), 3);
  it->second.descriptors.clear();
  ExpectRejected(map, *camera_, "keyframe " + std::to_string(it->first) + " has 0 descriptors");
}

TEST_F(SlamMapImportTest, RejectsAnotherCamera) {
  const Map map = original_.ToMap(params_, 0);
  CameraParams fisheye = params_;
  fisheye.model = CameraModel::kFisheye;
  ExpectRejected(map, *MakeCamera(fisheye), "map camera 0 is perspective 640x480, the tracking camera is fisheye 640x480");
  CameraParams smaller = params_;
  smaller.cols = 320;
  smaller.cx = 159.5;
  ExpectRejected(map, *MakeCamera(smaller), "tracking camera is perspective 320x480");
}

TEST_F(SlamMapImportTest, RejectsUnusableMaps) {
  Map empty;
  empty.cameras[0] = params_;
  ExpectRejected(empty, *camera_, "neither client keyframes nor lines");

  Map bad_keypoint = original_.ToMap(params_, 0);
  Observation& o = bad_keypoint.points.begin()->second.observations.front();
  o.keypoint_index = 1000000;
  ExpectRejected(bad_keypoint, *camera_, "no such keypoint");

  Map shared_keypoint = original_.ToMap(params_, 0);
  auto first = shared_keypoint.points.begin();
  auto second = std::next(first);
  second->second.observations.front() = first->second.observations.front();
  ExpectRejected(shared_keypoint, *camera_, "already observes point " + std::to_string(first->first));
}

}  // namespace
}  // namespace lcv::slam
