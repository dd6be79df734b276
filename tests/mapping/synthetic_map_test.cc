#include "mapping/synthetic_map.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <set>

namespace lcv::mapping {
namespace {

SyntheticMapOptions SmallOptions(std::uint64_t seed) {
  SyntheticMapOptions o;
  o.num_points = 400;
  o.num_keyframes = 12;
  o.seed = seed;
  o.pixel_noise_px = 1.0;
  return o;
}

Eigen::Vector2d ProjectPinhole(const slam::CameraParams& c, const slam::Rigid3d& cam_from_world,
                               const Eigen::Vector3d& p_in_world) {
  const Eigen::Vector3d p = cam_from_world * p_in_world;
  return Eigen::Vector2d(c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy);
}

TEST(SyntheticMap, CountsAndIdsAreUniqueMapWide) {
  const SyntheticMapOptions o = SmallOptions(7);
  const slam::Map map = MakeSyntheticPointMap(o);
  ASSERT_EQ(map.cameras.size(), 1u);
  EXPECT_EQ(map.keyframes.size(), 12u);
  EXPECT_EQ(map.points.size(), 400u);
  EXPECT_TRUE(map.lines.empty());
  EXPECT_TRUE(map.server_keyframes.empty());
  std::set<slam::Id> ids;
  for (const auto& [id, c] : map.cameras) ids.insert(id);
  for (const auto& [id, kf] : map.keyframes) {
    EXPECT_EQ(id, kf.id);
    ids.insert(id);
  }
  for (const auto& [id, p] : map.points) {
    EXPECT_EQ(id, p.id);
    ids.insert(id);
  }
  EXPECT_EQ(ids.size(), 1u + 12u + 400u);
  const slam::CameraParams& camera = map.cameras.begin()->second;
  EXPECT_EQ(camera.cols, 640);
  EXPECT_EQ(camera.rows, 360);
  EXPECT_EQ(camera.fx, 450.0);
}

TEST(SyntheticMap, DeterministicPerSeed) {
  const slam::Map a = MakeSyntheticPointMap(SmallOptions(3));
  const slam::Map b = MakeSyntheticPointMap(SmallOptions(3));
  const slam::Map c = MakeSyntheticPointMap(SmallOptions(4));
  ASSERT_EQ(a.points.size(), b.points.size());
  bool all_same = true, any_differs_from_c = false;
  for (const auto& [id, p] : a.points) {
    all_same &= (p.position == b.points.at(id).position) &&
                (p.covariance == b.points.at(id).covariance) &&
                (p.descriptor == b.points.at(id).descriptor);
    if (c.points.count(id)) any_differs_from_c |= p.position != c.points.at(id).position;
  }
  EXPECT_TRUE(all_same);
  EXPECT_TRUE(any_differs_from_c);
  for (const auto& [id, kf] : a.keyframes) {
    const auto& other = b.keyframes.at(id);
    ASSERT_EQ(kf.keypoints.size(), other.keypoints.size());
    for (size_t i = 0; i < kf.keypoints.size(); ++i) {
      EXPECT_EQ(kf.keypoints[i].x, other.keypoints[i].x);
      EXPECT_EQ(kf.keypoints[i].y, other.keypoints[i].y);
    }
  }
}

TEST(SyntheticMap, ObservationsConsistentBothWaysAndKeypointsNoisyProjections) {
  const SyntheticMapOptions o = SmallOptions(11);
  const slam::Map map = MakeSyntheticPointMap(o);
  const slam::CameraParams& camera = map.cameras.at(1);
  // Every keypoint is claimed by exactly one observation.
  std::map<slam::Id, std::vector<int>> claimed;
  for (const auto& [id, kf] : map.keyframes) {
    EXPECT_EQ(kf.descriptors.size(), kf.keypoints.size());
    claimed[id].assign(kf.keypoints.size(), 0);
  }
  double sum_sq = 0.0;
  int count = 0;
  for (const auto& [id, point] : map.points) {
    EXPECT_GE(static_cast<int>(point.observations.size()), o.min_observations);
    ASSERT_TRUE(point.descriptor.has_value());
    std::set<slam::Id> seen_by;
    for (const slam::Observation& obs : point.observations) {
      ASSERT_TRUE(map.keyframes.count(obs.keyframe_id));
      EXPECT_TRUE(seen_by.insert(obs.keyframe_id).second) << "a keyframe observes a point twice";
      const slam::Keyframe& kf = map.keyframes.at(obs.keyframe_id);
      ASSERT_LT(obs.keypoint_index, kf.keypoints.size());
      ++claimed[obs.keyframe_id][obs.keypoint_index];
      const slam::Keypoint& kp = kf.keypoints[obs.keypoint_index];
      const Eigen::Vector3d p_in_cam = kf.cam_from_world * point.position;
      EXPECT_GT(p_in_cam.z(), o.min_depth_m);
      const Eigen::Vector2d px = ProjectPinhole(camera, kf.cam_from_world, point.position);
      EXPECT_GE(px.x(), 0.0);
      EXPECT_LE(px.x(), camera.cols - 1);
      EXPECT_GE(px.y(), 0.0);
      EXPECT_LE(px.y(), camera.rows - 1);
      sum_sq += (Eigen::Vector2d(kp.x, kp.y) - px).squaredNorm();
      ++count;
      EXPECT_LE(slam::HammingDistance(*point.descriptor, kf.descriptors[obs.keypoint_index]),
                o.max_descriptor_bit_flips);
    }
  }
  for (const auto& [id, counts] : claimed) {
    for (int c : counts) EXPECT_EQ(c, 1) << "keyframe " << id;
  }
  // RMS of a 2D Gaussian with sigma 1 px per axis is sqrt(2).
  const double rms = std::sqrt(sum_sq / count);
  EXPECT_NEAR(rms, std::sqrt(2.0), 0.1) << "over " << count << " observations";
}

TEST(SyntheticMap, ZeroNoiseGivesExactKeypoints) {
  SyntheticMapOptions o = SmallOptions(5);
  o.pixel_noise_px = 0.0;
  const slam::Map map = MakeSyntheticPointMap(o);
  const slam::CameraParams& camera = map.cameras.at(1);
  for (const auto& [id, point] : map.points) {
    for (const slam::Observation& obs : point.observations) {
      const slam::Keyframe& kf = map.keyframes.at(obs.keyframe_id);
      const Eigen::Vector2d px = ProjectPinhole(camera, kf.cam_from_world, point.position);
      EXPECT_NEAR(kf.keypoints[obs.keypoint_index].x, px.x(), 1e-3);
      EXPECT_NEAR(kf.keypoints[obs.keypoint_index].y, px.y(), 1e-3);
    }
  }
}

TEST(SyntheticMap, CovariancesAreFirstOrderFromTheRays) {
  const SyntheticMapOptions o = SmallOptions(13);
  const slam::Map map = MakeSyntheticPointMap(o);
  const slam::CameraParams& camera = map.cameras.at(1);
  for (const auto& [id, point] : map.points) {
    const Eigen::Matrix3d& cov = point.covariance;
    ASSERT_TRUE(cov.allFinite());
    EXPECT_LT((cov - cov.transpose()).norm(), 1e-12 * cov.norm());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
    EXPECT_LE(eig.eigenvalues().maxCoeff(), o.prior_sigma_m * o.prior_sigma_m);
    // Recompute the information independently with numeric Jacobians of the pinhole projection.
    Eigen::Matrix3d info = Eigen::Matrix3d::Identity() / (o.prior_sigma_m * o.prior_sigma_m);
    for (const slam::Observation& obs : point.observations) {
      const slam::Rigid3d& T = map.keyframes.at(obs.keyframe_id).cam_from_world;
      Eigen::Matrix<double, 2, 3> J;
      for (int a = 0; a < 3; ++a) {
        const double h = 1e-6;
        Eigen::Vector3d plus = point.position, minus = point.position;
        plus(a) += h;
        minus(a) -= h;
        J.col(a) = (ProjectPinhole(camera, T, plus) - ProjectPinhole(camera, T, minus)) / (2 * h);
      }
      info += J.transpose() * J / (o.pixel_noise_px * o.pixel_noise_px);
    }
    const Eigen::Matrix3d product = info * cov;
    EXPECT_LT((product - Eigen::Matrix3d::Identity()).norm(), 1e-4) << "point " << id;
  }
}

TEST(SyntheticMap, PointsLieOnTheStreetSurfacesWithSomeClutter) {
  SyntheticMapOptions o = SmallOptions(17);
  o.num_points = 1000;
  const slam::Map map = MakeSyntheticPointMap(o);
  std::map<SyntheticSurface, int> histogram;
  for (const auto& [id, point] : map.points) {
    ++histogram[ClassifySyntheticPoint(o, point.position)];
    EXPECT_LE(std::abs(point.position.x()), o.street_half_width_m + 1e-9);
    EXPECT_LE(point.position.y(), o.camera_height_m + 1e-9);
    EXPECT_GE(point.position.y(), o.camera_height_m - o.facade_height_m - 1e-9);
  }
  EXPECT_GT(histogram[SyntheticSurface::kLeftFacade], 100);
  EXPECT_GT(histogram[SyntheticSurface::kRightFacade], 100);
  EXPECT_GT(histogram[SyntheticSurface::kGround], 100);
  EXPECT_GT(histogram[SyntheticSurface::kClutter], 20);
  EXPECT_LT(histogram[SyntheticSurface::kClutter], 300);
}

TEST(SyntheticMap, KeyframesDriveForwardAlongTheStreet) {
  const slam::Map map = MakeSyntheticPointMap(SmallOptions(1));
  double previous_z = -1e9;
  for (const auto& [id, kf] : map.keyframes) {
    const Eigen::Vector3d center = kf.cam_from_world.Center();
    EXPECT_GT(center.z(), previous_z);
    previous_z = center.z();
    EXPECT_LT(std::abs(center.x()), 1.0);
    EXPECT_NEAR(center.y(), 0.0, 1e-12);
    // Optical axis mostly along +z.
    const Eigen::Vector3d axis = kf.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
    EXPECT_GT(axis.z(), 0.98);
  }
}

TEST(SyntheticMap, RejectsBadOptions) {
  SyntheticMapOptions o;
  o.num_points = 0;
  EXPECT_TRUE(o.Problem().has_value());
  EXPECT_THROW(MakeSyntheticPointMap(o), std::logic_error);
  o = SyntheticMapOptions();
  o.pixel_noise_px = std::nan("");
  EXPECT_TRUE(o.Problem().has_value());
  o = SyntheticMapOptions();
  o.min_observations = o.num_keyframes + 1;
  EXPECT_TRUE(o.Problem().has_value());
  EXPECT_FALSE(SyntheticMapOptions().Problem().has_value());
}

}  // namespace
}  // namespace lcv::mapping
