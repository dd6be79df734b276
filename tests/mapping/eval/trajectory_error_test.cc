#include "mapping/eval/trajectory_error.h"

#include <cmath>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"

namespace lcv::mapping {
namespace {

constexpr std::uint64_t kSeed = 4242;

// A smooth non-planar trajectory (a helix with a wobbling heading), camera-to-world given.
Trajectory Helix(int count, double dt = 0.1) {
  Trajectory trajectory;
  for (int i = 0; i < count; ++i) {
    const double a = 0.2 * i;
    const Eigen::Vector3d centre(5 * std::cos(a), 5 * std::sin(a), 0.3 * i);
    const Eigen::Quaterniond rotation =
        slam::ExpSO3(Eigen::Vector3d(0.1 * std::sin(a), 0.05 * i, a + 0.1));
    trajectory.poses.push_back({i * dt, slam::Rigid3d(rotation, centre).Inverse()});
  }
  return trajectory;
}

// world_from_cam of a pose.
slam::Rigid3d W(const StampedPose& pose) { return pose.cam_from_world.Inverse(); }

Trajectory FromWorldFromCam(const std::vector<double>& times,
                            const std::vector<slam::Rigid3d>& world_from_cam) {
  Trajectory t;
  for (size_t i = 0; i < times.size(); ++i) t.poses.push_back({times[i], world_from_cam[i].Inverse()});
  return t;
}

Trajectory Stamps(const std::vector<double>& times) {
  return FromWorldFromCam(times, std::vector<slam::Rigid3d>(times.size()));
}

TEST(AssociationTest, NearestWithinMaxDifferenceLikeEvo) {
  const Trajectory gt = Stamps({0.0, 0.1, 0.2, 0.3, 0.4});
  const Trajectory est = Stamps({0.004, 0.195, 0.33, 0.41});  // shorter: est drives
  const TrajectoryAssociation a = AssociateByTimestamp(gt, est, 0.01);
  EXPECT_EQ(a.est_indices, (std::vector<int>{0, 1, 3}));
  EXPECT_EQ(a.gt_indices, (std::vector<int>{0, 2, 4}));

  // The estimate is longer: gt drives, and a pose of the longer one may be matched twice.
  const Trajectory est_long = Stamps({0.0, 0.05, 0.1001, 0.15, 0.2, 0.25, 0.3});
  const Trajectory gt_short = Stamps({0.1, 0.1002, 0.305});
  const TrajectoryAssociation b = AssociateByTimestamp(gt_short, est_long, 0.01);
  EXPECT_EQ(b.gt_indices, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(b.est_indices, (std::vector<int>{2, 2, 6}));

  // Ties go to the earlier pose (numpy argmin).
  const TrajectoryAssociation c = AssociateByTimestamp(Stamps({0.0, 1.0}), Stamps({0.5}), 0.5);
  EXPECT_EQ(c.gt_indices, (std::vector<int>{0}));
}

TEST(ErrorStatisticsTest, HandComputed) {
  const ErrorStatistics s = ComputeErrorStatistics({4, 1, 3, 2});
  EXPECT_EQ(s.count, 4);
  EXPECT_DOUBLE_EQ(s.sse, 30.0);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std, as numpy's default
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(ComputeErrorStatistics({3, 1, 2}).median, 2.0);
  EXPECT_EQ(ComputeErrorStatistics({}).count, 0);
}

TEST(ApeTest, HandComputedWithoutAlignment) {
  const Trajectory gt = Helix(20);
  std::vector<double> times;
  std::vector<slam::Rigid3d> shifted, rotated;
  const Eigen::Quaterniond two_degrees = slam::ExpSO3(Eigen::Vector3d(0, 0, 2.0 * M_PI / 180));
  for (const auto& pose : gt.poses) {
    times.push_back(pose.timestamp + 0.002);
    slam::Rigid3d w = W(pose);
    shifted.push_back(slam::Rigid3d(w.rotation, w.translation + Eigen::Vector3d(0.3, 0.4, 0)));
    rotated.push_back(slam::Rigid3d(w.rotation * two_degrees, w.translation));
  }
  TrajectoryErrorOptions options;  // no alignment, 10 ms
  const TrajectoryErrorReport a = ComputeApe(gt, FromWorldFromCam(times, shifted), options);
  ASSERT_FALSE(a.problem) << *a.problem;
  EXPECT_EQ(a.matched, 20);
  EXPECT_NEAR(a.translation.rmse, 0.5, 1e-12);
  EXPECT_NEAR(a.translation.max, 0.5, 1e-12);
  EXPECT_NEAR(a.rotation_deg.max, 0.0, 1e-6);

  const TrajectoryErrorReport b = ComputeApe(gt, FromWorldFromCam(times, rotated), options);
  EXPECT_NEAR(b.translation.max, 0.0, 1e-12);
  EXPECT_NEAR(b.rotation_deg.mean, 2.0, 1e-9);
  EXPECT_NEAR(b.rotation_deg.min, 2.0, 1e-9);
  ASSERT_EQ(b.rotation_errors_deg.size(), 20u);
  EXPECT_EQ(b.timestamps[3], gt.poses[3].timestamp);

  // The shift is a rigid motion: SE(3) alignment removes it.
  options.alignment = TrajectoryAlignment::kSE3;
  const TrajectoryErrorReport c = ComputeApe(gt, FromWorldFromCam(times, shifted), options);
  EXPECT_LT(c.translation.max, 1e-9);
  EXPECT_TRUE(c.gt_from_est.translation.isApprox(Eigen::Vector3d(-0.3, -0.4, 0), 1e-9));
}

TEST(ApeTest, Sim3AlignmentRecoversKnownSimilarityUnderNoise) {
  std::mt19937_64 rng(kSeed);
  std::normal_distribution<double> noise(0.0, 0.01);
  const Trajectory gt = Helix(100);
  // est_world_from_gt_world: the estimate lives in a frame rotated, shifted and scaled by 1/3.
  const slam::Sim3d est_from_gt(1.0 / 3.0, slam::ExpSO3(Eigen::Vector3d(0.3, -1.2, 0.7)),
                                Eigen::Vector3d(4, -2, 9));
  std::vector<double> times;
  std::vector<slam::Rigid3d> est;
  for (const auto& pose : gt.poses) {
    const slam::Rigid3d w = W(pose);
    times.push_back(pose.timestamp);
    est.push_back(slam::Rigid3d(
        est_from_gt.rotation * w.rotation,
        est_from_gt * w.translation + Eigen::Vector3d(noise(rng), noise(rng), noise(rng))));
  }
  const Trajectory est_trajectory = FromWorldFromCam(times, est);
  TrajectoryErrorOptions options;
  options.alignment = TrajectoryAlignment::kSim3;
  const TrajectoryErrorReport sim3 = ComputeApe(gt, est_trajectory, options);
  ASSERT_FALSE(sim3.problem);
  EXPECT_NEAR(sim3.gt_from_est.scale, 3.0, 0.01) << "seed " << kSeed;
  // Noise of 0.01 per axis in est units is 0.03 per axis in gt units: rmse ~ 0.03 * sqrt(3).
  EXPECT_LT(sim3.translation.rmse, 0.08);
  EXPECT_GT(sim3.translation.rmse, 0.02);
  EXPECT_LT(sim3.rotation_deg.max, 0.5);
  // Without the scale, the error is far larger.
  options.alignment = TrajectoryAlignment::kSE3;
  EXPECT_GT(ComputeApe(gt, est_trajectory, options).translation.rmse, 1.0);
}

// A street: 60 cameras along x with a lateral wobble of a few centimetres, looking ahead. The
// estimate is the truth in another similarity frame with centre noise and exact orientations.
// The centres alone leave the rotation about the street to the noise; the cameras'
// orientations pin it (align_with_orientations). centre_spread_ratio tells the two cases apart.
TEST(ApeTest, OrientationsPinTheRotationAboutAStraightPath) {
  std::mt19937_64 rng(kSeed);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<double> times;
  std::vector<slam::Rigid3d> gt_poses, est_poses;
  const slam::Sim3d est_from_gt(0.05, slam::ExpSO3(Eigen::Vector3d(0.4, 0.9, -0.3)),
                                Eigen::Vector3d(1, 2, 3));
  const Eigen::Quaterniond look_ahead = slam::ExpSO3(Eigen::Vector3d(-M_PI / 2, 0, 0)) *
                                        slam::ExpSO3(Eigen::Vector3d(0, M_PI / 2, 0));
  for (int i = 0; i < 60; ++i) {
    const double x = 1.5 * i;
    const Eigen::Vector3d centre(x, 0.05 * std::sin(0.3 * i), 1.6);
    const Eigen::Quaterniond rotation =
        slam::ExpSO3(Eigen::Vector3d(0, 0, 0.01 * std::sin(0.2 * i))) * look_ahead;
    times.push_back(0.1 * i);
    gt_poses.push_back(slam::Rigid3d(rotation, centre));
    const Eigen::Vector3d noisy = centre + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    est_poses.push_back(
        slam::Rigid3d(est_from_gt.rotation * rotation, est_from_gt * noisy));
  }
  const Trajectory gt = FromWorldFromCam(times, gt_poses);
  const Trajectory est = FromWorldFromCam(times, est_poses);
  TrajectoryErrorOptions options;
  options.alignment = TrajectoryAlignment::kSim3;
  const TrajectoryErrorReport centres = ComputeApe(gt, est, options);
  ASSERT_FALSE(centres.problem);
  EXPECT_LT(centres.centre_spread_ratio, 0.01);
  options.align_with_orientations = true;
  const TrajectoryErrorReport oriented = ComputeApe(gt, est, options);
  ASSERT_FALSE(oriented.problem);
  EXPECT_EQ(oriented.centre_spread_ratio, centres.centre_spread_ratio);
  // The true rotation comes back from the orientations; the rotation errors are (near) zero.
  const double turn_deg = oriented.gt_from_est.rotation.angularDistance(
                              est_from_gt.rotation.conjugate()) * 180.0 / M_PI;
  EXPECT_LT(turn_deg, 1e-6) << "seed " << kSeed;
  EXPECT_LT(oriented.rotation_deg.max, 1e-6);
  EXPECT_NEAR(oriented.gt_from_est.scale, 20.0, 0.1);
  // The centres' fit turns about the street by the noise: a rotation error many times larger.
  EXPECT_GT(centres.rotation_deg.median, 2.0) << "seed " << kSeed;  // 12.4 with this seed
  // Both fit the centres to the noise (0.02 per axis: rmse about 0.035).
  EXPECT_LT(centres.translation.rmse, 0.06);
  EXPECT_LT(oriented.translation.rmse, 0.08);
  // A helix spreads in every direction.
  options.align_with_orientations = false;
  EXPECT_GT(ComputeApe(Helix(100), Helix(100), options).centre_spread_ratio, 0.2);
}

TEST(RpeTest, HandComputedPairsDeltaAndScale) {
  const Trajectory gt = Helix(10);
  // Constant rigid offset of the whole trajectory: relative motions unchanged, RPE = 0.
  std::vector<double> times;
  std::vector<slam::Rigid3d> moved, doubled;
  const slam::Rigid3d offset(slam::ExpSO3(Eigen::Vector3d(0.1, 0.2, 0.3)), Eigen::Vector3d(1, 2, 3));
  for (const auto& pose : gt.poses) {
    times.push_back(pose.timestamp);
    moved.push_back(offset * W(pose));
    doubled.push_back(slam::Rigid3d(W(pose).rotation, 2.0 * W(pose).translation));
  }
  TrajectoryErrorOptions options;
  TrajectoryErrorReport r = ComputeRpe(gt, FromWorldFromCam(times, moved), options);
  ASSERT_FALSE(r.problem);
  EXPECT_EQ(r.translation_errors.size(), 9u);
  EXPECT_LT(r.translation.max, 1e-9);
  EXPECT_LT(r.rotation_deg.max, 1e-6);

  // Doubled centres, same rotations: E = Q_rel^-1 P_rel has translation R_i^T (c_j - c_i), so
  // the error equals the ground-truth step length.
  options.rpe_delta = 3;
  r = ComputeRpe(gt, FromWorldFromCam(times, doubled), options);
  ASSERT_EQ(r.translation_errors.size(), 3u);  // pairs (0,3), (3,6), (6,9)
  for (int k = 0; k < 3; ++k) {
    const double step = (W(gt.poses[3 * k + 3]).translation - W(gt.poses[3 * k]).translation).norm();
    EXPECT_NEAR(r.translation_errors[k], step, 1e-9) << k;
  }
  options.rpe_all_pairs = true;
  EXPECT_EQ(ComputeRpe(gt, FromWorldFromCam(times, doubled), options).translation_errors.size(), 7u);
  // Sim(3) alignment removes the factor 2.
  options.alignment = TrajectoryAlignment::kSim3;
  r = ComputeRpe(gt, FromWorldFromCam(times, doubled), options);
  EXPECT_NEAR(r.gt_from_est.scale, 0.5, 1e-12);
  EXPECT_LT(r.translation.max, 1e-9);
}

TEST(TrajectoryErrorTest, ProblemsAreReportedAsValues) {
  const Trajectory gt = Helix(10);
  Trajectory late = gt;
  for (auto& pose : late.poses) pose.timestamp += 100.0;
  TrajectoryErrorOptions options;
  const TrajectoryErrorReport none = ComputeApe(gt, late, options);
  ASSERT_TRUE(none.problem);
  EXPECT_NE(none.problem->find("no poses associated"), std::string::npos);

  // Collinear centres cannot be aligned.
  std::vector<double> times;
  std::vector<slam::Rigid3d> line;
  for (int i = 0; i < 5; ++i) {
    times.push_back(0.1 * i);
    line.push_back(slam::Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i, 0, 0)));
  }
  options.alignment = TrajectoryAlignment::kSE3;
  const TrajectoryErrorReport collinear =
      ComputeApe(FromWorldFromCam(times, line), FromWorldFromCam(times, line), options);
  ASSERT_TRUE(collinear.problem);
  EXPECT_NE(collinear.problem->find("degenerate"), std::string::npos);

  options.alignment = TrajectoryAlignment::kNone;
  options.rpe_delta = 20;
  EXPECT_TRUE(ComputeRpe(gt, gt, options).problem);
  EXPECT_EQ(ParseTrajectoryAlignment("sim3"), TrajectoryAlignment::kSim3);
  EXPECT_FALSE(ParseTrajectoryAlignment("Sim3d"));
}

TEST(TrajectoryErrorKitti00Test, GroundTruthAgainstItselfIsZero) {
  const std::string path = std::string(LCV_SHARED_DIR) + "/data/kitti00/poses.txt";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not found (shared KITTI data absent)";
  const Trajectory gt = ReadTrajectory(path, TrajectoryFormat::kKitti);
  for (const auto alignment :
       {TrajectoryAlignment::kNone, TrajectoryAlignment::kSE3, TrajectoryAlignment::kSim3}) {
    TrajectoryErrorOptions options;
    options.alignment = alignment;
    const TrajectoryErrorReport ape = ComputeApe(gt, gt, options);
    ASSERT_FALSE(ape.problem) << *ape.problem;
    EXPECT_EQ(ape.matched, 160);
    EXPECT_LT(ape.translation.max, 1e-9) << TrajectoryAlignmentName(alignment);
    EXPECT_LT(ape.rotation_deg.max, 1e-6);
    EXPECT_NEAR(ape.gt_from_est.scale, 1.0, 1e-12);
    const TrajectoryErrorReport rpe = ComputeRpe(gt, gt, options);
    EXPECT_EQ(rpe.translation_errors.size(), 159u);
    EXPECT_LT(rpe.translation.max, 1e-9);
  }
}

}  // namespace
}  // namespace lcv::mapping
