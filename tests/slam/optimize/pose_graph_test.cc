#include "slam/optimize/pose_graph.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::NumericJacobian;

Eigen::Vector3d Center(const Sim3d& cam_from_world) {
  return -(cam_from_world.rotation.conjugate() * cam_from_world.translation) /
         cam_from_world.scale;
}

// Poses on a circle of radius 10 m, looking outwards, as cam_from_world similarities (scale 1).
std::vector<Sim3d> CircleTrajectory(int count) {
  std::vector<Sim3d> poses;
  for (int i = 0; i < count; ++i) {
    const double angle = 2.0 * M_PI * i / count;
    const Rigid3d world_from_cam(ExpSO3(Eigen::Vector3d(0.0, -angle, 0.0)),
                                 Eigen::Vector3d(10.0 * std::cos(angle), 0.3 * std::sin(3 * angle),
                                                 10.0 * std::sin(angle)));
    poses.push_back(Sim3d(world_from_cam.Inverse()));
  }
  return poses;
}

Sim3d RandomSim3(std::mt19937* rng, double rotation_rad, double translation, double log_scale) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Vector7d delta;
  delta << translation * normal(*rng), translation * normal(*rng), translation * normal(*rng),
      rotation_rad * normal(*rng), rotation_rad * normal(*rng), rotation_rad * normal(*rng),
      log_scale * normal(*rng);
  return Sim3d::Exp(delta);
}

TEST(PoseGraphResidual, ZeroForConsistentVerticesAndFirstOrderLog) {
  std::mt19937 rng(3);
  const Sim3d a = RandomSim3(&rng, 0.5, 2.0, 0.2);
  const Sim3d b = RandomSim3(&rng, 0.5, 2.0, 0.2);
  PoseGraphEdge edge;
  edge.to_from_from = b * a.Inverse();
  EXPECT_LT(PoseGraphResidual(edge, a, b).norm(), 1e-12);
  // A small error E on the measurement shows as Log(E) to first order.
  Vector7d small;
  small << 1e-4, -2e-4, 3e-4, 2e-4, -1e-4, 1e-4, 3e-4;
  edge.to_from_from = Sim3d::Exp(small) * edge.to_from_from;
  EXPECT_LT((PoseGraphResidual(edge, a, b) - small).norm(), 1e-6);
}

TEST(OptimizePoseGraph, LoopClosureRemovesMoreThan90PercentOfTheDrift) {
  const unsigned seed = 5;
  std::mt19937 rng(seed);
  const int n = 40;
  const std::vector<Sim3d> truth = CircleTrajectory(n);
  // Odometry with drift: every relative measurement carries a small random error and a
  // systematic scale drift of 1% per step.
  std::vector<PoseGraphVertex> vertices(n);
  std::vector<PoseGraphEdge> edges;
  vertices[0].cam_from_world = truth[0];
  vertices[0].fixed = true;
  for (int i = 0; i + 1 < n; ++i) {
    const Sim3d true_relative = truth[i + 1] * truth[i].Inverse();
    Vector7d drift;
    drift << 0, 0, 0, 0, 0, 0, 0.01;
    const Sim3d measured = RandomSim3(&rng, 0.002, 0.01, 0.0) * Sim3d::Exp(drift) * true_relative;
    vertices[i + 1].cam_from_world = measured * vertices[i].cam_from_world;
    PoseGraphEdge edge;
    edge.from = i;
    edge.to = i + 1;
    edge.to_from_from = measured;
    edges.push_back(edge);
  }
  // The loop: the last keyframe recognizes the first one; the loop detector's Sim(3) is exact.
  PoseGraphEdge loop;
  loop.from = 0;
  loop.to = n - 1;
  loop.to_from_from = truth[n - 1] * truth[0].Inverse();
  edges.push_back(loop);

  auto loop_gap = [&](const std::vector<PoseGraphVertex>& v) {
    return PoseGraphResidual(loop, v[0].cam_from_world, v[n - 1].cam_from_world).norm();
  };
  auto mean_position_error = [&](const std::vector<PoseGraphVertex>& v) {
    double sum = 0.0;
    for (int i = 0; i < n; ++i) sum += (Center(v[i].cam_from_world) - Center(truth[i])).norm();
    return sum / n;
  };
  const double gap_before = loop_gap(vertices);
  const double error_before = mean_position_error(vertices);
  const PoseGraphReport report = OptimizePoseGraph(PoseGraphOptions(), edges, &vertices);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_LT(report.final_cost, report.initial_cost);
  const double gap_after = loop_gap(vertices);
  const double error_after = mean_position_error(vertices);
  RecordProperty("loop_gap", std::to_string(gap_before) + " -> " + std::to_string(gap_after));
  RecordProperty("mean_position_error_m",
                 std::to_string(error_before) + " -> " + std::to_string(error_after));
  EXPECT_LT(gap_after, 0.1 * gap_before) << "seed " << seed;
  EXPECT_LT(error_after, 0.1 * error_before)
      << "seed " << seed << ": mean position error " << error_before << " -> " << error_after;
  // The fixed vertex did not move.
  EXPECT_LT((vertices[0].cam_from_world.translation - truth[0].translation).norm(), 1e-12);
}

TEST(OptimizePoseGraph, ConsistentGraphStaysPut) {
  std::mt19937 rng(7);
  const std::vector<Sim3d> truth = CircleTrajectory(10);
  std::vector<PoseGraphVertex> vertices(truth.size());
  std::vector<PoseGraphEdge> edges;
  for (size_t i = 0; i < truth.size(); ++i) vertices[i].cam_from_world = truth[i];
  vertices[0].fixed = true;
  for (size_t i = 0; i < truth.size(); ++i) {
    for (size_t j = i + 1; j < std::min(truth.size(), i + 3); ++j) {
      PoseGraphEdge edge;
      edge.from = static_cast<int>(i);
      edge.to = static_cast<int>(j);
      edge.to_from_from = truth[j] * truth[i].Inverse();
      edges.push_back(edge);
    }
  }
  const PoseGraphReport report = OptimizePoseGraph(PoseGraphOptions(), edges, &vertices);
  ASSERT_TRUE(report.success);
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_LT((vertices[i].cam_from_world.translation - truth[i].translation).norm(), 1e-9);
    EXPECT_NEAR(vertices[i].cam_from_world.scale, 1.0, 1e-9);
  }
}

TEST(OptimizePoseGraph, BadEdgeIsABug) {
  std::vector<PoseGraphVertex> vertices(2);
  std::vector<PoseGraphEdge> edges(1);
  edges[0].from = 0;
  edges[0].to = 5;
  EXPECT_THROW(OptimizePoseGraph(PoseGraphOptions(), edges, &vertices), std::logic_error);
  PoseGraphOptions options;
  options.max_iterations = 0;
  EXPECT_NE(options.Problem().find("max_iterations"), std::string::npos);
}

}  // namespace
}  // namespace lcv::slam
