#include "privacy/map_alignment.h"

#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"

namespace lcv::privacy {
namespace {

// A small map: 6 keyframes along a curved path (not collinear), points with covariances, one
// line with its information matrix and a restored point, one server keyframe.
slam::Map MakeMap() {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  slam::Map map;
  for (int k = 0; k < 6; ++k) {
    slam::Keyframe kf;
    kf.id = 10 + k;
    kf.timestamp = 0.1 * k;
    const Eigen::Vector3d centre(k, 0.3 * k * k, 0.1 * u(rng));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.2 * u(rng), Eigen::Vector3d::UnitY()));
    kf.cam_from_world = slam::Rigid3d(q, Eigen::Vector3d::Zero());
    kf.cam_from_world.translation = -(q * centre);
    map.keyframes[kf.id] = kf;
  }
  for (slam::Id id = 100; id < 110; ++id) {
    slam::PointLandmark p;
    p.id = id;
    p.position = Eigen::Vector3d(u(rng), u(rng), 5 + u(rng));
    p.covariance = Eigen::Vector3d(0.01, 0.02, 0.03).asDiagonal();
    map.points[id] = p;
  }
  slam::LineLandmark l;
  l.id = 200;
  l.line = slam::Line3d(Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0, 0.6, 0.8));
  l.information = slam::LineInformation(l.line.direction, Eigen::Matrix3d::Identity() * 0.01);
  l.restored_point = l.line.PointAt(0.5);
  map.lines[200] = l;
  return map;
}

TEST(MapAlignment, RecoversTheSimilarityAndTransformsEverything) {
  const slam::Map map = MakeMap();
  const slam::Sim3d truth(2.5, Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                          Eigen::Vector3d(4, -1, 2));
  mapping::Trajectory gt;
  for (const auto& [id, kf] : map.keyframes) {
    // Ground truth at slightly different timestamps (within the tolerance).
    gt.poses.push_back({kf.timestamp + 0.005, slam::TransformPose(truth, kf.cam_from_world)});
  }
  std::string problem;
  const auto alignment = AlignMapToGroundTruth(map, gt, 0.02, &problem);
  ASSERT_TRUE(alignment) << problem;
  EXPECT_EQ(alignment->matched, 6);
  EXPECT_LT(alignment->rmse, 1e-9);
  EXPECT_NEAR(alignment->gt_from_map.scale, 2.5, 1e-9);
  EXPECT_LT(slam::AngularDistance(alignment->gt_from_map.rotation, truth.rotation), 1e-9);

  const slam::Map moved = TransformMap(map, alignment->gt_from_map);
  for (const auto& [id, kf] : moved.keyframes) {
    EXPECT_LT((kf.cam_from_world.Center() - truth * map.keyframes.at(id).cam_from_world.Center()).norm(), 1e-8);
  }
  const Eigen::Matrix3d R = truth.rotation.toRotationMatrix();
  for (const auto& [id, p] : moved.points) {
    EXPECT_LT((p.position - truth * map.points.at(id).position).norm(), 1e-8);
    EXPECT_LT((p.covariance - 6.25 * R * map.points.at(id).covariance * R.transpose()).norm(), 1e-10);
  }
  const slam::LineLandmark& l = moved.lines.at(200);
  EXPECT_LT(l.line.Distance(truth * map.lines.at(200).line.PointAt(2.0)), 1e-8) << "same line";
  // Omega transforms as the inverse covariance: eq. (1) with the scaled, rotated covariance.
  const Eigen::Matrix3d expected = slam::LineInformation(l.line.direction, 6.25 * 0.01 * Eigen::Matrix3d::Identity());
  EXPECT_LT((l.information - expected).norm(), 1e-6 * expected.norm());
  EXPECT_LT((*l.restored_point - truth * *map.lines.at(200).restored_point).norm(), 1e-8);
}

// A nearly straight path with centre noise (a street): the centres alone leave the roll about
// the path loose; the keyframes' orientations fix it.
TEST(MapAlignment, OrientationsFixTheRollAboutAStraightPath) {
  std::mt19937_64 rng(8);
  std::normal_distribution<double> noise(0.0, 0.02);
  slam::Map map;
  const slam::Sim3d truth(3.0, Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(0.2, 1, 0.3).normalized())),
                          Eigen::Vector3d(1, 2, 3));
  mapping::Trajectory gt;
  for (int k = 0; k < 30; ++k) {
    slam::Keyframe kf;
    kf.id = 1 + k;
    kf.timestamp = k;
    const Eigen::Vector3d centre(0.5 * k, 0.01 * std::sin(0.3 * k), 0.0);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1 * std::sin(0.2 * k), Eigen::Vector3d::UnitY()));
    kf.cam_from_world = slam::Rigid3d(q, -(q * centre));
    map.keyframes[kf.id] = kf;
    slam::Rigid3d truth_pose = slam::TransformPose(truth, kf.cam_from_world);
    // The ground truth's centres are noisy (the SLAM map's drift), its orientations are not.
    const Eigen::Vector3d c = truth_pose.Center() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    truth_pose.translation = -(truth_pose.rotation * c);
    gt.poses.push_back({kf.timestamp, truth_pose});
  }
  const auto alignment = AlignMapToGroundTruth(map, gt);
  ASSERT_TRUE(alignment);
  EXPECT_LT(slam::AngularDistance(alignment->gt_from_map.rotation, truth.rotation) * 180 / M_PI, 0.2);
  EXPECT_NEAR(alignment->gt_from_map.scale, 3.0, 0.01);
}

TEST(MapAlignment, TooFewMatchesOrCollinearKeyframesAreReported) {
  slam::Map map = MakeMap();
  mapping::Trajectory gt;
  gt.poses.push_back({0.0, map.keyframes.at(10).cam_from_world});
  gt.poses.push_back({0.1, map.keyframes.at(11).cam_from_world});
  gt.poses.push_back({5.0, map.keyframes.at(12).cam_from_world});  // no keyframe near t = 5
  std::string problem;
  EXPECT_FALSE(AlignMapToGroundTruth(map, gt, 0.02, &problem));
  EXPECT_NE(problem.find("2 keyframes matched"), std::string::npos) << problem;

  for (auto& [id, kf] : map.keyframes) {
    kf.cam_from_world = slam::Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-(id - 10.0), 0, 0));
  }
  gt.poses.clear();
  for (const auto& [id, kf] : map.keyframes) gt.poses.push_back({kf.timestamp, kf.cam_from_world});
  EXPECT_FALSE(AlignMapToGroundTruth(map, gt, 0.02, &problem));
  EXPECT_NE(problem.find("degenerate"), std::string::npos) << problem;
}

}  // namespace
}  // namespace lcv::privacy
