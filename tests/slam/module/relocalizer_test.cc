#include "slam/module/relocalizer.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "slam/data/slam_map_import.h"
#include "tests/slam/camera/camera_test_cameras.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam {
namespace {

constexpr int kNumKeyframes = 10;
constexpr double kStep = 1.0;  // m between keyframes

CameraParams EquirectangularParams() {
  CameraParams p;
  p.name = "equirectangular";
  p.model = CameraModel::kEquirectangular;
  p.cols = 1024;
  p.rows = 512;
  return p;
}

// A map of a slab scene seen by kNumKeyframes keyframes along a lateral path, built through the
// persistent model and ImportSlamMap (a saved map being reused), with a vocabulary trained on its
// descriptors and every keyframe in the BoW database.
// The map, vocabulary and database of one camera model (built once per model: training the
// vocabulary dominates the test's run time).
struct World {
  std::unique_ptr<Camera> camera;
  testing::SyntheticScene scene;
  SlamMap map;
  Vocabulary vocabulary;
  BowDatabase database;
};

std::unique_ptr<World> BuildWorld(const CameraParams& params) {
  auto world = std::make_unique<World>();
  world->camera = MakeCamera(params);
  world->scene = testing::MakeSlabScene(1800, -4.0, 13.0, 4.0, 7.0, 41);
  const std::vector<Rigid3d> poses = testing::MakeLateralTrajectory(kNumKeyframes, kStep);
  std::mt19937_64 rng(42);
  testing::ObservationNoise noise;
  noise.clutter = 30;
  Map map;
  map.cameras[0] = params;
  std::map<int, std::vector<Observation>> observations;  // scene point -> observations
  std::vector<std::vector<OrbDescriptor>> training;
  for (int k = 0; k < kNumKeyframes; ++k) {
    const testing::SyntheticFrame s =
        testing::ObserveScene(world->scene, *world->camera, poses[k], noise, &rng);
    Keyframe kf;
    kf.id = 10 + k;
    kf.camera_id = 0;
    kf.timestamp = k;
    kf.cam_from_world = poses[k];
    kf.keypoints = s.keypoints;
    kf.descriptors = s.descriptors;
    for (std::size_t i = 0; i < s.point_index.size(); ++i) {
      if (s.point_index[i] >= 0) {
        observations[s.point_index[i]].push_back({kf.id, static_cast<std::uint32_t>(i)});
      }
    }
    training.push_back(kf.descriptors);
    map.keyframes[kf.id] = std::move(kf);
  }
  for (const auto& [j, obs] : observations) {
    if (obs.size() < 2) continue;
    PointLandmark point;
    point.id = 1000 + j;  // landmark of scene point j
    point.position = world->scene.points_in_world[j];
    point.observations = obs;
    map.points[point.id] = point;
  }
  world->map = ImportSlamMap(map, *world->camera, ScaleLevels());

  VocabularyOptions vocabulary_options;
  vocabulary_options.branching = 10;
  vocabulary_options.depth = 4;
  world->vocabulary = Vocabulary::Train(training, vocabulary_options);
  for (auto& [id, kf] : world->map.mutable_keyframes()) {
    world->vocabulary.Transform(kf.descriptors, &kf.bow.overwrite(), &kf.direct_index.overwrite(), kDirectIndexLevel);
    world->database.Add(id, kf.bow);
  }
  return world;
}

// A slab scene seen by kNumKeyframes keyframes along a lateral path, built through the
// persistent model and ImportSlamMap (a saved map being reused), with a vocabulary trained on its
// descriptors and every keyframe in the BoW database.
class RelocalizerTest : public ::testing::TestWithParam<CameraParams> {
 protected:
  void SetUp() override {
    static std::map<CameraModel, std::unique_ptr<World>> worlds;
    std::unique_ptr<World>& world = worlds[GetParam().model];
    if (!world) world = BuildWorld(GetParam());
    camera_ = world->camera.get();
    scene_ = &world->scene;
    map_ = &world->map;
    vocabulary_ = &world->vocabulary;
    database_ = &world->database;
  }

  // A frame seen from cam_from_world in the given scene (keypoint -> scene point in *truth).
  Frame Observe(const testing::SyntheticScene& scene, const Rigid3d& cam_from_world,
                const testing::ObservationNoise& noise, std::uint64_t seed,
                std::vector<int>* truth = nullptr) {
    std::mt19937_64 rng(seed);
    testing::SyntheticFrame s = testing::ObserveScene(scene, *camera_, cam_from_world, noise, &rng);
    Frame frame;
    frame.id = 500;
    frame.camera = camera_;
    frame.keypoints = s.keypoints;
    frame.descriptors = s.descriptors;
    PrepareFrame(&frame);
    if (truth) *truth = s.point_index;
    return frame;
  }

  // A viewpoint between keyframes 4 and 5, off the path, turned by a few degrees.
  Rigid3d NewViewpoint() const {
    const Eigen::Vector3d center(4.5 * kStep, 0.25, -0.3);
    const Eigen::Quaterniond world_from_cam = ExpSO3(Eigen::Vector3d(0.03, -0.06, 0.04));
    return Rigid3d(world_from_cam, center).Inverse();
  }

  // Fraction of the frame's matches whose landmark is the keypoint's true scene point.
  double CorrectMatchFraction(const Frame& frame, const std::vector<int>& truth) const {
    int matched = 0, correct = 0;
    for (int i = 0; i < frame.num_keypoints(); ++i) {
      if (frame.landmark_ids[i] == kInvalidId) continue;
      ++matched;
      correct += truth[i] >= 0 && frame.landmark_ids[i] == static_cast<Id>(1000 + truth[i]);
    }
    return matched ? static_cast<double>(correct) / matched : 0.0;
  }

  static void ExpectPoseNear(const Rigid3d& estimate, const Rigid3d& truth, double max_m,
                             double max_rad) {
    EXPECT_LT((estimate.Center() - truth.Center()).norm(), max_m);
    EXPECT_LT(estimate.rotation.angularDistance(truth.rotation), max_rad);
  }

  const Camera* camera_ = nullptr;
  const testing::SyntheticScene* scene_ = nullptr;
  const SlamMap* map_ = nullptr;
  const Vocabulary* vocabulary_ = nullptr;
  const BowDatabase* database_ = nullptr;
};

TEST_P(RelocalizerTest, FindsThePoseFromANewViewpoint) {
  const Rigid3d truth_pose = NewViewpoint();
  std::vector<int> truth;
  Frame frame = Observe(*scene_, truth_pose, testing::ObservationNoise(), 7, &truth);
  const auto result = Relocalize(*vocabulary_, *database_, *map_, RelocalizerOptions(), 1, &frame);
  ASSERT_TRUE(result.has_value());
  EXPECT_TRUE(frame.has_pose);
  EXPECT_EQ(frame.reference_keyframe_id, result->keyframe_id);
  EXPECT_NE(map_->FindKeyframe(result->keyframe_id), nullptr);
  EXPECT_GE(result->num_inliers, RelocalizerOptions().min_inliers);
  EXPECT_GE(result->num_candidates_tried, 1);
  EXPECT_EQ(frame.NumTrackedLandmarks(), result->num_inliers);
  EXPECT_GT(CorrectMatchFraction(frame, truth), 0.97);
  ExpectPoseNear(frame.cam_from_world, truth_pose, 0.03, 0.005);
  EXPECT_FALSE(frame.bow.empty());
  EXPECT_FALSE(frame.direct_index.empty());
}

TEST_P(RelocalizerTest, ProjectionSearchAddsTheLocalMapsLandmarks) {
  // BoW matching reaches only the candidate's landmarks; asking for more inliers than that makes
  // the relocalizer search the landmarks of the candidate's covisible keyframes by projection.
  const Rigid3d truth_pose = NewViewpoint();
  std::vector<int> truth;
  Frame first = Observe(*scene_, truth_pose, testing::ObservationNoise(), 13, &truth);
  Frame second = first;
  const auto bow_only = Relocalize(*vocabulary_, *database_, *map_, RelocalizerOptions(), 1, &first);
  ASSERT_TRUE(bow_only.has_value());
  RelocalizerOptions more;
  more.min_inliers = bow_only->num_inliers + 50;
  const auto result = Relocalize(*vocabulary_, *database_, *map_, more, 1, &second);
  ASSERT_TRUE(result.has_value()) << "BoW-only inliers " << bow_only->num_inliers;
  EXPECT_GE(result->num_inliers, more.min_inliers);
  EXPECT_EQ(second.NumTrackedLandmarks(), result->num_inliers);
  EXPECT_GT(CorrectMatchFraction(second, truth), 0.97);
  ExpectPoseNear(second.cam_from_world, truth_pose, 0.03, 0.005);
  // Beyond what the map holds in view, it fails (and leaves no matches).
  RelocalizerOptions impossible;
  impossible.min_inliers = second.num_keypoints() + 1;
  Frame third = Observe(*scene_, truth_pose, testing::ObservationNoise(), 13);
  EXPECT_FALSE(Relocalize(*vocabulary_, *database_, *map_, impossible, 1, &third).has_value());
  EXPECT_EQ(third.NumTrackedLandmarks(), 0);
}

TEST_P(RelocalizerTest, ToleratesHalfTheFeaturesBeingClutterOrOutliers) {
  const Rigid3d truth_pose = NewViewpoint();
  testing::ObservationNoise noise;
  noise.clutter = 0;
  const int num_observed = Observe(*scene_, truth_pose, noise, 8).num_keypoints();
  noise.clutter = num_observed;  // as many random features as real ones
  std::vector<int> truth;
  Frame frame = Observe(*scene_, truth_pose, noise, 8, &truth);
  // And a fifth of the real ones moved elsewhere in the image: right descriptor, wrong place.
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<float> ux(2.f, camera_->cols() - 3.f), uy(2.f, camera_->rows() - 3.f);
  for (int i = 0; i < frame.num_keypoints(); i += 5) {
    if (truth[i] < 0) continue;
    frame.keypoints[i].x = ux(rng);
    frame.keypoints[i].y = uy(rng);
    truth[i] = -1;
  }
  PrepareFrame(&frame);
  const auto result = Relocalize(*vocabulary_, *database_, *map_, RelocalizerOptions(), 2, &frame);
  ASSERT_TRUE(result.has_value());
  EXPECT_GT(CorrectMatchFraction(frame, truth), 0.97);
  ExpectPoseNear(frame.cam_from_world, truth_pose, 0.03, 0.005);
}

TEST_P(RelocalizerTest, FailsCleanlyInAnUnrelatedPlace) {
  const testing::SyntheticScene elsewhere = testing::MakeSlabScene(1800, -4.0, 13.0, 4.0, 7.0, 99);
  Frame frame = Observe(elsewhere, NewViewpoint(), testing::ObservationNoise(), 10);
  const Rigid3d prior(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3));
  frame.cam_from_world = prior;
  frame.has_pose = false;
  const auto result = Relocalize(*vocabulary_, *database_, *map_, RelocalizerOptions(), 3, &frame);
  EXPECT_FALSE(result.has_value());
  EXPECT_FALSE(frame.has_pose);
  EXPECT_EQ(frame.cam_from_world.translation, prior.translation);
  EXPECT_EQ(frame.NumTrackedLandmarks(), 0);
  for (const Id id : frame.landmark_ids) EXPECT_EQ(id, kInvalidId);
}

TEST_P(RelocalizerTest, IsDeterministicForASeed) {
  Frame a = Observe(*scene_, NewViewpoint(), testing::ObservationNoise(), 11);
  Frame b = a;
  const auto ra = Relocalize(*vocabulary_, *database_, *map_, RelocalizerOptions(), 5, &a);
  const auto rb = Relocalize(*vocabulary_, *database_, *map_, RelocalizerOptions(), 5, &b);
  ASSERT_TRUE(ra && rb);
  EXPECT_EQ(ra->keyframe_id, rb->keyframe_id);
  EXPECT_EQ(ra->num_inliers, rb->num_inliers);
  EXPECT_EQ(a.cam_from_world.translation, b.cam_from_world.translation);
  EXPECT_EQ(a.landmark_ids, b.landmark_ids);
}

TEST_P(RelocalizerTest, CandidatesAreTheKeyframesNearTheViewpoint) {
  Frame frame = Observe(*scene_, NewViewpoint(), testing::ObservationNoise(), 12);
  vocabulary_->Transform(frame.descriptors, &frame.bow, &frame.direct_index, kDirectIndexLevel);
  const std::vector<Id> candidates =
      RelocalizationCandidates(*database_, *map_, frame.bow, RelocalizerOptions());
  ASSERT_FALSE(candidates.empty());
  EXPECT_LE(candidates.size(), 10u + 3u);  // group bests + best own scores
  EXPECT_EQ(std::set<Id>(candidates.begin(), candidates.end()).size(), candidates.size());
  // The keyframe with the best score of its own is always tried.
  const Id best_alone = database_->Query(frame.bow, 1).front().keyframe_id;
  EXPECT_EQ(std::count(candidates.begin(), candidates.end(), best_alone), 1);
  RelocalizerOptions groups_only;
  groups_only.max_candidates = 1;
  groups_only.raw_score_candidates = 0;
  const std::vector<Id> first = RelocalizationCandidates(*database_, *map_, frame.bow, groups_only);
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first.front(), candidates.front());
  // The part above holds for every camera; the one below only for the perspective one: a wide
  // camera sees the whole slab from every keyframe, so no place is told apart by its view.
  if (GetParam().model != CameraModel::kPerspective) return;
  // The viewpoint sits between keyframes 4 and 5 (ids 14, 15), 1 m apart, a ~6.6 m wide view at
  // the slab's middle depth: the best group's keyframe is one of the nearest ones, and the far
  // end of the path (ids 10, 19) is not a candidate.
  EXPECT_GE(candidates.front(), 13u);
  EXPECT_LE(candidates.front(), 16u);
  for (const Id id : candidates) {
    EXPECT_NE(id, 10u);
    EXPECT_NE(id, 19u);
  }
}

INSTANTIATE_TEST_SUITE_P(Cameras, RelocalizerTest,
                         ::testing::Values(testing::SyntheticPinhole(), test::TumViFisheyeParams(),
                                           EquirectangularParams()),
                         [](const ::testing::TestParamInfo<CameraParams>& info) {
                           return std::string(CameraModelName(info.param.model));
                         });

TEST(RelocalizerOptions, Problem) {
  EXPECT_FALSE(RelocalizerOptions().Problem());
  RelocalizerOptions bad;
  bad.min_inliers = 2;
  EXPECT_TRUE(bad.Problem());
  bad = RelocalizerOptions();
  bad.max_angular_error_rad = -1.0;
  EXPECT_TRUE(bad.Problem());
  bad = RelocalizerOptions();
  bad.max_ransac_error_px = 0.0;
  EXPECT_TRUE(bad.Problem());
  bad.max_angular_error_rad = 0.01;  // given in radians: the pixel setting is not used
  EXPECT_FALSE(bad.Problem());
}

}  // namespace
}  // namespace lcv::slam
