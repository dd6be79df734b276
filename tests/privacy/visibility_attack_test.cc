#include "privacy/visibility_attack.h"

#include <gtest/gtest.h>

#include "privacy/reference_match.h"
#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

// Each hidden point is seen by the keyframes listing its line (within the synthetic map's depth
// range), so it lies inside the feasible interval: the midpoint is at most half the interval
// (= tau / risk) away from it.
TEST(VisibilityAttack, HiddenPointInsideFeasibleInterval) {
  const std::uint64_t seed = 13;
  mapping::SyntheticMapOptions synth;
  synth.num_points = 1500;
  synth.num_keyframes = 30;
  synth.seed = seed;
  const slam::Map points = mapping::MakeSyntheticPointMap(synth);
  const slam::Map lines = testing::MakeLineCloud(points, seed);
  VisibilityAttackOptions options;
  options.near_m = 0.9 * synth.min_depth_m;
  options.far_m = 1.01 * synth.max_depth_m;
  options.risk_tolerance_m = 0.5;
  const LineAttackResult result = RunVisibilityAttack(lines, options);
  const ReferenceMatch match = MatchReference(lines, points);
  int estimated = 0, high_risk = 0;
  for (std::size_t i = 0; i < result.size(); ++i) {
    ASSERT_TRUE(match.matched[i]);
    if (!result.has_estimate[i]) continue;
    ++estimated;
    ASSERT_GT(result.risk[i], 0.0);
    const double half_length = options.risk_tolerance_m / result.risk[i];
    const double error = (result.estimates[i] - match.hidden_points[i]).norm();
    EXPECT_LE(error, std::max(half_length, options.risk_tolerance_m) + 1e-6) << "line " << i;
    high_risk += result.risk[i] >= 0.5;
  }
  EXPECT_EQ(estimated, 1500) << "every line is seen by >= 2 keyframes";
  EXPECT_GT(high_risk, 0);
}

// Planted leak: a line seen by keyframes looking at the point from many sides is pinned down
// (short interval, high risk); the same line seen from one keyframe is not.
TEST(VisibilityAttack, ManyViewsPinThePoint) {
  slam::Map map;
  slam::CameraParams cam;
  cam.cols = 640;
  cam.rows = 480;
  cam.fx = cam.fy = 300;  // wide field of view
  cam.cx = 319.5;
  cam.cy = 239.5;
  map.cameras[1] = cam;
  const Eigen::Vector3d x(0, 0, 10);
  const Eigen::Vector3d d = Eigen::Vector3d(1, 0.2, 0.3).normalized();
  for (slam::Id line_id : {100, 101}) {
    map.lines[line_id].id = line_id;
    map.lines[line_id].line = slam::Line3d(x - d.dot(x) * d, d);
  }
  // Cameras on a circle around x, narrow field of view, all looking at x.
  for (int k = 0; k < 12; ++k) {
    const double a = 2 * M_PI * k / 12;
    const Eigen::Vector3d c = x + 5.0 * Eigen::Vector3d(std::cos(a), 0.3, std::sin(a));
    const Eigen::Vector3d z = (x - c).normalized();
    const Eigen::Vector3d xr = Eigen::Vector3d::UnitY().cross(z).normalized();
    Eigen::Matrix3d world_from_cam_rot;
    world_from_cam_rot << xr, z.cross(xr), z;
    slam::Rigid3d world_from_cam(Eigen::Quaterniond(world_from_cam_rot), c);
    slam::ServerKeyframe kf;
    kf.id = 10 + k;
    kf.camera_id = 1;
    kf.cam_from_world = world_from_cam.Inverse();
    kf.line_ids = {100};
    if (k == 0) kf.line_ids.push_back(101);
    map.server_keyframes[kf.id] = kf;
  }
  VisibilityAttackOptions options;
  options.far_m = 30;
  options.risk_tolerance_m = 0.5;
  const LineAttackResult r = RunVisibilityAttack(map, options);
  ASSERT_TRUE(r.has_estimate[0]);
  ASSERT_TRUE(r.has_estimate[1]);
  EXPECT_LT((r.estimates[0] - x).norm(), 2.5);
  EXPECT_GT(r.risk[0], 2.0 * r.risk[1]);
}

TEST(VisibilityAttack, UnseenLinesGetNoEstimate) {
  slam::Map map;
  map.lines[1].line = slam::Line3d(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  const LineAttackResult r = RunVisibilityAttack(map);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_FALSE(r.has_estimate[0]);
  EXPECT_EQ(r.risk[0], 0.0);
}

}  // namespace
}  // namespace lcv::privacy
