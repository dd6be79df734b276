#include "slam/module/line_cloud_view_registration.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "slam/solve/p6l.h"

namespace lcv::slam {
namespace {

constexpr double kDegree = M_PI / 180.0;

Eigen::Vector3d RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// A bearing turned by a random small angle (radians, standard deviation per axis).
Eigen::Vector3d Perturb(const Eigen::Vector3d& bearing, double sigma, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, sigma);
  return (ExpSO3(Eigen::Vector3d(n(rng), n(rng), n(rng))) * bearing).normalized();
}

TEST(ViewBearingPlaneResidual, JacobianMatchesNumericDifferentiation) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Sim3d server_from_client(std::exp(u(rng)), ExpSO3(Eigen::Vector3d(u(rng), u(rng), u(rng))),
                                   Eigen::Vector3d(u(rng), u(rng), u(rng)) * 5.0);
    const Rigid3d client(ExpSO3(Eigen::Vector3d(u(rng), u(rng), u(rng))),
                         Eigen::Vector3d(u(rng), u(rng), u(rng)));
    const Line3d line(Eigen::Vector3d(u(rng), u(rng), u(rng)) * 10.0, RandomUnit(rng));
    const Eigen::Vector3d bearing = RandomUnit(rng);
    double r = 0.0;
    Eigen::Matrix<double, 1, 7> jacobian;
    ASSERT_TRUE(ViewBearingPlaneResidual(server_from_client, client, bearing, line, &r, &jacobian));
    for (int k = 0; k < 7; ++k) {
      const double h = 1e-6;
      Vector7d delta = Vector7d::Zero();
      delta(k) = h;
      double plus = 0.0, minus = 0.0;
      ASSERT_TRUE(ViewBearingPlaneResidual(Sim3d::Exp(delta) * server_from_client, client, bearing,
                                           line, &plus, nullptr));
      ASSERT_TRUE(ViewBearingPlaneResidual(Sim3d::Exp(-delta) * server_from_client, client,
                                           bearing, line, &minus, nullptr));
      EXPECT_NEAR(jacobian(k), (plus - minus) / (2.0 * h), 1e-6 * (1.0 + std::abs(jacobian(k))))
          << "trial " << trial << " parameter " << k;
    }
  }
}

// A street-like scene: lines through points 8-40 m ahead of a camera that drives along +z, and
// client keyframes whose map is the server's under the inverse of a known similarity. Each view's
// p6L pose is the true one with noise (centre sigma 0.05 m per axis, rotation 0.1 degrees), its inlier
// bearings the true ones with 1 mrad noise.
struct ViewScene {
  Sim3d server_from_client;
  std::vector<LineCloudView> views;
};

ViewScene MakeScene(int num_views, double step_m, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> lateral(-10.0, 10.0), height(-3.0, 5.0),
      ahead(8.0, 40.0);
  std::normal_distribution<double> centre_noise(0.0, 0.05), angle_noise(0.0, 0.1 * kDegree);
  ViewScene scene;
  scene.server_from_client = Sim3d(7.5, ExpSO3(Eigen::Vector3d(0.2, -0.4, 0.3)),
                                   Eigen::Vector3d(12.0, -3.0, 40.0));
  const Sim3d client_from_server = scene.server_from_client.Inverse();
  for (int v = 0; v < num_views; ++v) {
    // Camera looking along +z (cam_from_world rotation identity), moving forward.
    const Eigen::Vector3d centre(0.3 * std::sin(v), 0.0, step_m * v);
    const Rigid3d server_pose(Eigen::Quaterniond::Identity(), -centre);
    LineCloudView view;
    view.keyframe_id = 100 + v;
    view.client_cam_from_world = TransformPose(client_from_server, server_pose);
    view.server_cam_from_world = Rigid3d(
        ExpSO3(Eigen::Vector3d(angle_noise(rng), angle_noise(rng), angle_noise(rng))) *
            server_pose.rotation,
        Eigen::Vector3d::Zero());
    const Eigen::Vector3d noisy_centre =
        centre + Eigen::Vector3d(centre_noise(rng), centre_noise(rng), centre_noise(rng));
    view.server_cam_from_world.translation = -(view.server_cam_from_world.rotation * noisy_centre);
    for (int i = 0; i < 60; ++i) {
      const Eigen::Vector3d point = centre + Eigen::Vector3d(lateral(rng), height(rng), ahead(rng));
      const Eigen::Vector3d direction = RandomUnit(rng);
      view.lines.push_back(Line3d(point + 3.0 * direction, direction));
      view.bearings.push_back(Perturb((server_pose * point).normalized(), 1e-3, rng));
    }
    scene.views.push_back(std::move(view));
  }
  return scene;
}

LineCloudViewRegistrationOptions Options() {
  LineCloudViewRegistrationOptions options;
  options.max_error_rad = 3.0 / 500.0;  // 3 px at a focal length of 500 px
  return options;
}

void ExpectClose(const Sim3d& estimate, const Sim3d& truth) {
  EXPECT_NEAR(estimate.scale / truth.scale, 1.0, 0.01);
  EXPECT_LT(AngularDistance(estimate.rotation, truth.rotation), 0.2 * kDegree);
  // Where a client point 20 m ahead of the first view lands in the server frame.
  const Eigen::Vector3d probe = truth.Inverse() * Eigen::Vector3d(0.0, 0.0, 20.0);
  EXPECT_LT((estimate * probe - truth * probe).norm(), 0.2);
}

TEST(RegisterFromViews, RecoversTheSimilarityFromNoisyViews) {
  const ViewScene scene = MakeScene(5, 1.5, 1);
  const LineCloudViewRegistration result = RegisterFromViews(scene.views, Options());
  ASSERT_TRUE(result.success) << result.failure;
  EXPECT_EQ(result.view_keyframe_ids.size(), 5u);
  EXPECT_GE(result.num_inliers, 250);
  ExpectClose(result.server_from_client, scene.server_from_client);
}

TEST(RegisterFromViews, LeavesOutAViewWhoseP6LPoseIsWrong) {
  ViewScene scene = MakeScene(5, 1.5, 2);
  // p6L found a wrong pose for one keyframe: 3 m off and turned by 5 degrees.
  LineCloudView& wrong = scene.views[2];
  wrong.server_cam_from_world =
      Rigid3d(ExpSO3(Eigen::Vector3d(0.0, 5.0 * kDegree, 0.0)), Eigen::Vector3d(3.0, 0.0, 0.0)) *
      wrong.server_cam_from_world;
  const LineCloudViewRegistration result = RegisterFromViews(scene.views, Options());
  ASSERT_TRUE(result.success) << result.failure;
  EXPECT_EQ(result.view_keyframe_ids.size(), 4u);
  for (const Id id : result.view_keyframe_ids) EXPECT_NE(id, wrong.keyframe_id);
  ExpectClose(result.server_from_client, scene.server_from_client);
}

TEST(RegisterFromViews, RefusesViewsTooCloseTogetherForTheScale) {
  // Five views within 0.4 m, lines ~20 m away: the span is 0.02 line distances.
  const ViewScene scene = MakeScene(5, 0.1, 3);
  const LineCloudViewRegistration result = RegisterFromViews(scene.views, Options());
  EXPECT_FALSE(result.success);
  EXPECT_NE(result.failure.find("span"), std::string::npos) << result.failure;
}

TEST(RegisterFromViews, NeedsEnoughViewsThatAgree) {
  ViewScene scene = MakeScene(3, 1.5, 4);
  EXPECT_FALSE(RegisterFromViews({scene.views[0], scene.views[1]}, Options()).success);
  // Three views, two of them wrong in different ways: no three agree.
  scene.views[1].server_cam_from_world.translation += Eigen::Vector3d(4.0, 0.0, 0.0);
  scene.views[2].server_cam_from_world.translation += Eigen::Vector3d(0.0, -4.0, 0.0);
  const LineCloudViewRegistration result = RegisterFromViews(scene.views, Options());
  EXPECT_FALSE(result.success);
  EXPECT_NE(result.failure.find("agreeing"), std::string::npos) << result.failure;
}

TEST(RegisterFromViews, NeedsAnInlierThreshold) {
  const ViewScene scene = MakeScene(4, 1.5, 5);
  LineCloudViewRegistrationOptions options;  // max_error_rad left at 0
  const LineCloudViewRegistration result = RegisterFromViews(scene.views, options);
  EXPECT_FALSE(result.success);
  EXPECT_NE(result.failure.find("max_error_rad"), std::string::npos);
}

}  // namespace
}  // namespace lcv::slam
