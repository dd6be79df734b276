#include "slam/module/line_cloud_registration.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "tests/slam/module/registration_scene.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::MakeRegistrationScene;
using testing::RegistrationScene;
using testing::RegistrationSceneOptions;
using testing::TestCameraParams;

constexpr double kRadToDeg = 180.0 / M_PI;

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

LineCloudRegistration Register(const RegistrationScene& scene,
                               const LineCloudRegistrationOptions& options = {}) {
  return RegisterToLineCloud(scene.views, scene.points, scene.lines, scene.server_points, options);
}

// The recovered similarity within 1 degree and 1% scale, the ckf centre within 1% of the scene
// depth, the restored X' near the true points their keypoints observe, and (almost) no restored
// X' or point match from a wrong descriptor match. A wrong match survives only when its line
// happens to pass within the inlier threshold of the true point (then its X' is still right):
// at most 2% of them.
void ExpectAccurate(const RegistrationScene& scene, const LineCloudRegistration& result,
                    std::uint64_t seed) {
  ASSERT_TRUE(result.success) << result.failure << " (seed " << seed << ")";
  const Sim3d& truth = scene.server_from_client_true;
  const Sim3d& found = result.server_from_client;
  EXPECT_LT(AngularDistance(found.rotation, truth.rotation) * kRadToDeg, 1.0) << "seed " << seed;
  EXPECT_LT(std::abs(found.scale / truth.scale - 1.0), 0.01) << "seed " << seed;
  const Eigen::Vector3d ckf_center = TransformPose(found, scene.views[0].cam_from_world).Center();
  EXPECT_LT((ckf_center - scene.true_cam_from_server[0].Center()).norm(), 0.08)
      << "seed " << seed << " (scene depths 4-12 m)";
  std::vector<double> relative_errors;
  int wrong_lines = 0;
  for (const auto& r : result.restored) {
    wrong_lines += r.landmark_id != r.line_id;
    const Eigen::Vector3d& truth_point = scene.true_points[r.landmark_id];
    relative_errors.push_back((r.position_in_server - truth_point).norm() / truth_point.norm());
  }
  EXPECT_LE(wrong_lines, std::max<int>(1, 0.02 * result.restored.size())) << "seed " << seed;
  if (!relative_errors.empty()) {
    // Tails: X' slides along its line, which the rays of a 0.2-0.6 m baseline pin down to a
    // few percent when the line runs close to the viewing direction.
    EXPECT_LT(Median(relative_errors), 0.005) << "seed " << seed;
    EXPECT_LT(*std::max_element(relative_errors.begin(), relative_errors.end()), 0.06)
        << "seed " << seed;
  }
  int wrong_points = 0;
  for (const auto& [landmark, server_point] : result.point_matches) {
    wrong_points += landmark != server_point;
  }
  EXPECT_LE(wrong_points, std::max<int>(1, 0.02 * result.point_matches.size())) << "seed " << seed;
}

class RegistrationAllCameras : public ::testing::TestWithParam<CameraModel> {};

TEST_P(RegistrationAllCameras, RecoversTheSimilarityAndRestoresPointsOnTheirLines) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(GetParam()));
  for (const std::uint64_t seed : {1u, 2u}) {
    RegistrationSceneOptions options;
    options.seed = seed;
    const RegistrationScene scene = MakeRegistrationScene(*camera, options);
    const LineCloudRegistration result = Register(scene);
    ExpectAccurate(scene, result, seed);
    EXPECT_EQ(result.method, "p4l");
    EXPECT_EQ(result.num_point_point_matches, 0);
    EXPECT_GT(result.restored.size(), 200u) << "seed " << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(Cameras, RegistrationAllCameras,
                         ::testing::Values(CameraModel::kPerspective, CameraModel::kFisheye,
                                           CameraModel::kEquirectangular),
                         [](const auto& info) { return std::string(CameraModelName(info.param)); });

TEST(RegisterToLineCloud, SurvivesThirtyToFiftyPercentWrongMatchesAtSmallAndLargeScales) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  for (const double wrong : {0.3, 0.5}) {
    for (const double scale : {0.3, 3.0}) {
      RegistrationSceneOptions options;
      options.wrong_match_ratio = wrong;
      options.scale = scale;
      options.rotation_deg = 70.0;
      options.seed = static_cast<std::uint64_t>(100 * wrong + 10 * scale);
      const RegistrationScene scene = MakeRegistrationScene(*camera, options);
      const LineCloudRegistration result = Register(scene);
      SCOPED_TRACE("wrong " + std::to_string(wrong) + ", scale " + std::to_string(scale));
      ExpectAccurate(scene, result, options.seed);
      // The wrong matches reach RANSAC and are rejected there.
      EXPECT_GT(result.num_point_line_matches - result.num_point_line_inliers,
                0.8 * wrong * options.num_points);
    }
  }
}

// The server's unit is its own: a line cloud in millimetres or kilometres seen by a client whose
// unit is about its first scene depth. The scale range used to stop at 1e3, which rejected a
// street in centimetres (lcv slam on an overlap pair: "degenerate scale 1619.87").
TEST(RegisterToLineCloud, RegistersALineCloudInAnyUnit) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  for (const double scale : {2e-4, 1.6e3, 4e4}) {
    RegistrationSceneOptions options;
    options.scale = scale;
    options.seed = 7;
    const RegistrationScene scene = MakeRegistrationScene(*camera, options);
    SCOPED_TRACE("server units per client unit " + std::to_string(scale));
    ExpectAccurate(scene, Register(scene), options.seed);
  }
}

TEST(RegisterToLineCloud, FreeingTheGroupScaleInTheBaTakesTheScaleFromThePixels) {
  // 3% depth noise on the client points: the RANSAC scale is biased (1.5-3% in the bench); the
  // BA with the rigid group's scale free gets it from the observations.
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  LineCloudRegistrationOptions refine;
  refine.refine_scale_in_ba = true;
  for (const std::uint64_t seed : {31u, 32u, 33u}) {
    RegistrationSceneOptions options;
    options.depth_noise_ratio = 0.03;
    options.wrong_match_ratio = 0.3;
    options.seed = seed;
    const RegistrationScene scene = MakeRegistrationScene(*camera, options);
    const LineCloudRegistration refined = Register(scene, refine);
    ExpectAccurate(scene, refined, seed);
    const LineCloudRegistration held = Register(scene);
    ASSERT_TRUE(held.success) << held.failure;
    const double truth = scene.server_from_client_true.scale;
    EXPECT_LE(std::abs(refined.server_from_client.scale / truth - 1.0),
              std::abs(held.server_from_client.scale / truth - 1.0))
        << "seed " << seed;
  }
}

TEST(RegisterToLineCloud, RejectsTheLineCloudOfAnotherPlaceWithAReason) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions options;
  options.seed = 5;
  const RegistrationScene client = MakeRegistrationScene(*camera, options);
  // Another place that looks alike: other points (another seed), each line carrying the
  // descriptor of a client point, so every client point finds a match.
  options.seed = 6;
  RegistrationScene elsewhere = MakeRegistrationScene(*camera, options);
  for (size_t j = 0; j < client.points.size(); ++j) {
    elsewhere.lines[j].descriptor = client.points[j].descriptor;
  }
  const LineCloudRegistration result = RegisterToLineCloud(
      client.views, client.points, elsewhere.lines, elsewhere.server_points, {});
  EXPECT_FALSE(result.success);
  EXPECT_GE(result.num_point_line_matches, 250);
  EXPECT_EQ(result.failure.rfind("RANSAC (p4l): ", 0), 0u) << result.failure;

  // Unrelated descriptors too: stopped at matching.
  options.seed = 7;
  const RegistrationScene unrelated = MakeRegistrationScene(*camera, options);
  const LineCloudRegistration no_matches = RegisterToLineCloud(
      client.views, client.points, unrelated.lines, unrelated.server_points, {});
  EXPECT_FALSE(no_matches.success);
  EXPECT_EQ(no_matches.method, "");
  EXPECT_NE(no_matches.failure.find("matches < 20"), std::string::npos) << no_matches.failure;
}

TEST(RegisterToLineCloud, PicksP3PWhenServerPointsDominate) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions options;
  options.num_lines_of_points = 100;  // N_PL ~ 100
  options.num_server_points = 200;    // N_PP ~ 200: 100 / 200 < 4/3
  options.num_other_server_points = 100;
  options.wrong_match_ratio = 0.3;  // decoys: other lines and server points
  options.seed = 11;
  const RegistrationScene scene = MakeRegistrationScene(*camera, options);
  const LineCloudRegistration result = Register(scene);
  EXPECT_EQ(result.method, "p3p");
  ExpectAccurate(scene, result, options.seed);
  EXPECT_GT(result.restored.size(), 50u);
  EXPECT_GT(result.point_matches.size(), 100u);

  // The same place with mostly lines: 250 / 60 > 4/3.
  options.num_lines_of_points = 250;
  options.num_server_points = 60;
  const RegistrationScene mostly_lines = MakeRegistrationScene(*camera, options);
  const LineCloudRegistration p4l = Register(mostly_lines);
  EXPECT_EQ(p4l.method, "p4l");
  ExpectAccurate(mostly_lines, p4l, options.seed);
}

TEST(RegisterToLineCloud, RegistersOnServerPointsAlone) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions options;
  options.num_lines_of_points = 0;
  options.num_other_lines = 0;
  options.num_server_points = 300;
  options.num_other_server_points = 150;
  options.wrong_match_ratio = 0.4;
  options.scale = 0.5;
  options.seed = 12;
  const RegistrationScene scene = MakeRegistrationScene(*camera, options);
  ASSERT_TRUE(scene.lines.empty());
  const LineCloudRegistration result = Register(scene);
  EXPECT_EQ(result.method, "p3p");
  ExpectAccurate(scene, result, options.seed);
  EXPECT_TRUE(result.restored.empty());
  EXPECT_GT(result.point_matches.size(), 150u);
}

TEST(RegisterToLineCloud, RejectsCollinearPoints) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions options;
  options.collinear = true;
  options.seed = 21;
  const RegistrationScene scene = MakeRegistrationScene(*camera, options);
  const LineCloudRegistration result = Register(scene);
  EXPECT_FALSE(result.success);
  EXPECT_GE(result.num_point_line_matches, 250);
  EXPECT_EQ(result.failure.rfind("RANSAC (p4l): ", 0), 0u) << result.failure;
  EXPECT_TRUE(std::isfinite(result.server_from_client.scale));
}

TEST(RegisterToLineCloud, IsDeterministicForASeed) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions options;
  options.wrong_match_ratio = 0.4;
  const RegistrationScene scene = MakeRegistrationScene(*camera, options);
  const LineCloudRegistration a = Register(scene);
  const LineCloudRegistration b = Register(scene);
  ASSERT_TRUE(a.success) << a.failure;
  EXPECT_EQ(a.num_inliers, b.num_inliers);
  EXPECT_EQ(a.server_from_client.translation, b.server_from_client.translation);
}

// A registered client's loop check: with the prior (the map as it is) agreeing with the matches,
// nothing is sampled; with a prior that does not hold, the registration runs as without one.
TEST(RegisterToLineCloud, APriorThatHoldsSkipsRansac) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions scene_options;
  scene_options.wrong_match_ratio = 0.3;
  const RegistrationScene scene = MakeRegistrationScene(*camera, scene_options);
  LineCloudRegistrationOptions options;
  options.prior = scene.server_from_client_true;
  const LineCloudRegistration held = Register(scene, options);
  EXPECT_TRUE(held.prior_holds);
  EXPECT_FALSE(held.success);
  EXPECT_EQ(held.num_ransac_trials, 0);
  EXPECT_GE(held.num_inliers, 0.6 * scene_options.num_points) << held.failure;
  EXPECT_EQ(held.failure.rfind("the prior model holds: ", 0), 0u) << held.failure;

  options.prior = Sim3d();  // the identity: 40 degrees and a scale of 2.5 away
  const LineCloudRegistration registered = Register(scene, options);
  EXPECT_FALSE(registered.prior_holds);
  EXPECT_GT(registered.num_ransac_trials, 0);
  ExpectAccurate(scene, registered, scene_options.seed);
  const LineCloudRegistration without_prior = Register(scene);
  EXPECT_EQ(registered.server_from_client.translation, without_prior.server_from_client.translation);
}

// RANSAC stops once a model that could pass the verification would have been sampled: here no
// correspondence is right, and a model needs 30 of the 40 (a loop check's bar).
TEST(RegisterToLineCloud, StopsSamplingWhenNoModelCouldPass) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions scene_options;
  scene_options.num_points = 40;
  scene_options.num_lines_of_points = 40;
  scene_options.num_other_lines = 60;
  scene_options.wrong_match_ratio = 1.0;
  const RegistrationScene scene = MakeRegistrationScene(*camera, scene_options);
  LineCloudRegistrationOptions options;
  options.min_inliers = 30;
  const LineCloudRegistration result = Register(scene, options);
  ASSERT_EQ(result.num_point_line_matches, 40);
  EXPECT_FALSE(result.success);
  // An all-inlier sample of a model with 30 of 40 inliers: 0.75^4 per draw, 19 draws for 0.999.
  EXPECT_GT(result.num_ransac_trials, 0);
  EXPECT_LE(result.num_ransac_trials, 19);

  options.min_inliers = 41;  // more than there are matches
  const LineCloudRegistration impossible = Register(scene, options);
  EXPECT_FALSE(impossible.success);
  EXPECT_EQ(impossible.num_ransac_trials, 0);
  EXPECT_EQ(impossible.failure, "RANSAC (p4l): 40 matches cannot give 41 inliers");
}

TEST(RegisterToLineCloud, TooFewMatchesIsAValueNotAnError) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions options;
  options.num_points = 12;
  options.num_lines_of_points = 12;
  options.num_other_lines = 20;
  const RegistrationScene scene = MakeRegistrationScene(*camera, options);
  const LineCloudRegistration result = Register(scene);
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.failure, "12 point-line + 0 point-point matches < 20");
  // Nothing at all.
  const LineCloudRegistration empty = RegisterToLineCloud(scene.views, {}, {}, {}, {});
  EXPECT_FALSE(empty.success);
  EXPECT_EQ(empty.failure, "0 point-line + 0 point-point matches < 20");
}

TEST(RegisterToLineCloud, BrokenPreconditionsThrow) {
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  RegistrationSceneOptions options;
  options.num_points = 30;
  RegistrationScene scene = MakeRegistrationScene(*camera, options);
  scene.points[3].observations.push_back({7, Eigen::Vector2d(1.0, 1.0), 1.0});
  EXPECT_THROW(Register(scene), std::logic_error);
  EXPECT_THROW(RegisterToLineCloud({}, scene.points, scene.lines, {}, {}), std::logic_error);
  LineCloudRegistrationOptions bad;
  bad.ratio = 0.0;
  EXPECT_NE(bad.Problem(), "");
  EXPECT_EQ(LineCloudRegistrationOptions().Problem(), "");
}

}  // namespace
}  // namespace lcv::slam
