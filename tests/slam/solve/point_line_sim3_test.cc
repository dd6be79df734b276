#include "slam/solve/point_line_sim3.h"

#include <random>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "slam/solve/ransac.h"
#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

using test::MakePointLineScene;
using test::PointLineScene;
using test::Sim3Error;

TEST(Sim3PointLine, ExactDataRecoversTruth) {
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    for (int n : {6, 20}) {
      const PointLineScene scene = MakePointLineScene(seed, n, 0.0, 0.0);
      Sim3d S;
      ASSERT_EQ(SolveSim3PointLineLinear(scene.points.data(), scene.lines.data(), n, nullptr, &S),
                1);
      EXPECT_LT(Sim3Error(S, scene.server_from_client), 1e-8);
    }
  }
}

TEST(Sim3PointLine, NoisyDataBoundedErrorAndRefinementHelps) {
  const PointLineScene scene = MakePointLineScene(11, 100, 0.02, 0.0);
  Sim3d linear;
  ASSERT_EQ(SolveSim3PointLineLinear(scene.points.data(), scene.lines.data(), 100, nullptr,
                                     &linear),
            1);
  EXPECT_LT(Sim3Error(linear, scene.server_from_client), 0.1);
  Sim3d refined = linear;
  double cost = 0;
  ASSERT_GE(RefineSim3PointLine(scene.points.data(), scene.lines.data(), 100, nullptr, 20,
                                &refined, &cost),
            1);
  double linear_cost = 0;
  for (int i = 0; i < 100; ++i) {
    linear_cost += SquaredPointLineDistance(linear, scene.points[i], scene.lines[i]);
  }
  EXPECT_LE(cost, linear_cost);
  EXPECT_LT(Sim3Error(refined, scene.server_from_client), 0.03);
}

TEST(Sim3PointLine, DegenerateInputReturnsZero) {
  PointLineScene scene = MakePointLineScene(12, 10, 0.0, 0.0);
  Sim3d S;
  EXPECT_EQ(SolveSim3PointLineLinear(scene.points.data(), scene.lines.data(), 5, nullptr, &S), 0);
  // All lines parallel: the translation along them is free.
  PointLineScene parallel = scene;
  for (auto& line : parallel.lines) line.direction = Eigen::Vector3d::UnitZ();
  EXPECT_EQ(SolveSim3PointLineLinear(parallel.points.data(), parallel.lines.data(), 10, nullptr, &S),
            0);
  // All points identical.
  PointLineScene same = scene;
  for (auto& p : same.points) p = Eigen::Vector3d(1, 2, 3);
  EXPECT_EQ(SolveSim3PointLineLinear(same.points.data(), same.lines.data(), 10, nullptr, &S), 0);
  std::vector<int> three = {0, 1, 2};
  EXPECT_EQ(RefineSim3PointLine(scene.points.data(), scene.lines.data(), 10, &three, 5, &S), -1);
}

TEST(Sim3PointLine, RansacWithOutliers) {
  for (double outliers : {0.3, 0.5}) {
    SCOPED_TRACE("outliers " + std::to_string(outliers));
    const PointLineScene scene = MakePointLineScene(13, 200, 0.01, outliers);
    RansacOptions options;
    options.max_error = 0.05;
    options.random_seed = 13;
    options.max_num_trials = 5000;
    const Sim3PointLineEstimator estimator(scene.points.data(), scene.lines.data(), 200);
    const auto report = Ransac(options, estimator);
    ASSERT_TRUE(report.success);
    EXPECT_LT(Sim3Error(report.model, scene.server_from_client), 0.02);
    int correct = 0;
    for (int i = 0; i < 200; ++i) correct += report.inlier_mask[i] == scene.is_inlier[i];
    // An outlier's random line may pass within the threshold of the true point.
    EXPECT_GE(correct, 195);
  }
}

TEST(RefineSim3PointLine, JacobianMatchesCentralDifferences) {
  const PointLineScene scene = MakePointLineScene(14, 10, 0.05, 0.0);
  const Sim3d& S = scene.server_from_client;
  for (int i = 0; i < 10; ++i) {
    const Line3d& line = scene.lines[i];
    const Eigen::Vector3d helper =
        std::abs(line.direction.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    Eigen::Matrix<double, 3, 2> B;
    B.col(0) = (helper - line.direction.dot(helper) * line.direction).normalized();
    B.col(1) = line.direction.cross(B.col(0));
    const Eigen::Vector3d y = S * scene.points[i];
    Eigen::Matrix<double, 3, 7> J_y;
    J_y.leftCols<3>().setIdentity();
    J_y.block<3, 3>(0, 3) = -SkewSymmetric(y);
    J_y.col(6) = y;
    const Eigen::Matrix<double, 2, 7> J = B.transpose() * J_y;
    const double h = 1e-6;
    for (int k = 0; k < 7; ++k) {
      Vector7d delta = Vector7d::Zero();
      delta(k) = h;
      const Eigen::Vector2d plus = B.transpose() * (Sim3d::Exp(delta) * S * scene.points[i] - line.anchor);
      const Eigen::Vector2d minus = B.transpose() * (Sim3d::Exp(-delta) * S * scene.points[i] - line.anchor);
      EXPECT_LT((J.col(k) - (plus - minus) / (2 * h)).norm(), 1e-6 * (1.0 + J.col(k).norm()))
          << "correspondence " << i << " coordinate " << k;
    }
  }
}

// Ceres twin: the same point-to-line cost over (log scale, quaternion, translation).
struct PointLineCost {
  PointLineCost(const Eigen::Vector3d& point, const Line3d& line) : point(point), line(line) {}
  template <typename T>
  bool operator()(const T* log_scale, const T* q_xyzw, const T* t, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_xyzw);
    const Eigen::Matrix<T, 3, 1> y = ceres::exp(log_scale[0]) * (q * point.cast<T>()) +
                                     Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t);
    const Eigen::Matrix<T, 3, 1> diff = y - line.anchor.cast<T>();
    const Eigen::Matrix<T, 3, 1> r = diff - line.direction.cast<T>() * line.direction.cast<T>().dot(diff);
    residual[0] = r(0);
    residual[1] = r(1);
    residual[2] = r(2);
    return true;
  }
  Eigen::Vector3d point;
  Line3d line;
};

TEST(RefineSim3PointLine, AgreesWithCeresTwin) {
  const PointLineScene scene = MakePointLineScene(15, 60, 0.03, 0.0);
  std::mt19937_64 rng(15);
  Vector7d delta;
  for (int k = 0; k < 7; ++k) delta(k) = std::normal_distribution<double>(0, 0.03)(rng);
  const Sim3d start = Sim3d::Exp(delta) * scene.server_from_client;
  Sim3d hand = start;
  RefineSim3PointLine(scene.points.data(), scene.lines.data(), 60, nullptr, 50, &hand);

  double log_scale = std::log(start.scale);
  Eigen::Quaterniond q = start.rotation;
  Eigen::Vector3d t = start.translation;
  ceres::Problem problem;
  for (int i = 0; i < 60; ++i) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PointLineCost, 3, 1, 4, 3>(
                                 new PointLineCost(scene.points[i], scene.lines[i])),
                             nullptr, &log_scale, q.coeffs().data(), t.data());
  }
  problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold);
  ceres::Solver::Options options;
  options.max_num_iterations = 200;
  options.function_tolerance = 1e-16;
  options.gradient_tolerance = 1e-16;
  options.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Sim3d twin(std::exp(log_scale), q.normalized(), t);
  EXPECT_LT(Sim3Error(hand, twin), 1e-7);
}

}  // namespace
}  // namespace lcv::slam
