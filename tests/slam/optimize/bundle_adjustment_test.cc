#include "slam/optimize/bundle_adjustment.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/line3.h"
#include "slam/geometry/so3.h"
#include "slam/optimize/residuals.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::RandomPose;
using testing::TestCameraParams;

// A street-like scene: keyframes on a line along x looking at +z, landmarks in a box in front.
// A fraction of the landmarks is published as lines (random direction through the hidden point,
// anchor moved along it); the client observes the hidden point as x' and restores X'.
struct Scene {
  std::unique_ptr<Camera> camera;
  BundleProblem truth;
  std::vector<Eigen::Vector3d> hidden_points;  // per line, the point X_L it replaced
  std::vector<char> observation_is_outlier;
};

Rigid3d KeyframePose(double x, double yaw) {
  const Rigid3d world_from_cam(ExpSO3(Eigen::Vector3d(0.0, yaw, 0.0)),
                               Eigen::Vector3d(x, 0.1 * std::sin(x), 0.0));
  return world_from_cam.Inverse();
}

Scene MakeScene(int num_keyframes, int num_landmarks, double line_ratio, double noise_px,
                double outlier_ratio, std::mt19937* rng) {
  Scene scene;
  scene.camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  BundleProblem& p = scene.truth;
  for (int i = 0; i < num_keyframes; ++i) {
    BundleKeyframe keyframe;
    keyframe.id = i;
    keyframe.cam_from_world = KeyframePose(0.8 * i, 0.03 * std::cos(i));
    keyframe.camera = scene.camera.get();
    p.keyframes.push_back(keyframe);
  }
  const double length = 0.8 * (num_keyframes - 1);
  const Eigen::Matrix3d point_covariance = 0.05 * 0.05 * Eigen::Matrix3d::Identity();
  for (int j = 0; j < num_landmarks; ++j) {
    const Eigen::Vector3d x(-4.0 + (length + 8.0) * unit(*rng), -2.5 + 5.0 * unit(*rng),
                            6.0 + 8.0 * unit(*rng));
    const bool as_line = unit(*rng) < line_ratio;
    int landmark;
    if (as_line) {
      BundleLine line;
      line.id = 1000 + j;
      const Eigen::Vector3d d = UniformUnitVector(unit(*rng), unit(*rng));
      line.line = Line3d(x + (4.0 * unit(*rng) - 2.0) * d, d);
      line.information = LineInformation(d, point_covariance);
      line.restored_point = x;
      landmark = static_cast<int>(p.lines.size());
      p.lines.push_back(line);
      scene.hidden_points.push_back(x);
    } else {
      BundlePoint point;
      point.id = 1000 + j;
      point.position = x;
      landmark = static_cast<int>(p.points.size());
      p.points.push_back(point);
    }
    for (int i = 0; i < num_keyframes; ++i) {
      const auto px = scene.camera->Project(p.keyframes[i].cam_from_world * x);
      if (!px || !scene.camera->InImage(*px, 5.0)) continue;
      BundleObservation obs;
      obs.keyframe = i;
      obs.landmark = landmark;
      obs.on_line = as_line;
      const bool outlier = unit(*rng) < outlier_ratio;
      obs.observed_px = outlier ? Eigen::Vector2d(639.0 * unit(*rng), 359.0 * unit(*rng))
                                : Eigen::Vector2d(*px + Eigen::Vector2d(noise(*rng), noise(*rng)));
      p.observations.push_back(obs);
      scene.observation_is_outlier.push_back(outlier);
    }
  }
  return scene;
}

void PerturbClient(BundleProblem* p, double rotation_rad, double translation_m, double point_m,
                   std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, point_m);
  for (BundleKeyframe& keyframe : p->keyframes) {
    if (!keyframe.fixed) {
      keyframe.cam_from_world =
          RandomPose(rng, rotation_rad, translation_m) * keyframe.cam_from_world;
    }
  }
  for (BundlePoint& point : p->points) {
    point.position += Eigen::Vector3d(noise(*rng), noise(*rng), noise(*rng));
  }
  for (BundleLine& line : p->lines) {
    line.restored_point += Eigen::Vector3d(noise(*rng), noise(*rng), noise(*rng));
  }
}

double MaxCenterError(const BundleProblem& a, const BundleProblem& b) {
  double error = 0.0;
  for (size_t i = 0; i < a.keyframes.size(); ++i) {
    error = std::max(error, (a.keyframes[i].cam_from_world.Center() -
                             b.keyframes[i].cam_from_world.Center()).norm());
  }
  return error;
}

double MedianPointError(const BundleProblem& a, const BundleProblem& b) {
  std::vector<double> errors;
  for (size_t i = 0; i < a.points.size(); ++i) {
    errors.push_back((a.points[i].position - b.points[i].position).norm());
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

TEST(SolveBundleAdjustment, LocalBARecoversPosesPointsAndFlagsOutliers) {
  const unsigned seed = 31;
  std::mt19937 rng(seed);
  Scene scene = MakeScene(10, 600, 0.3, 1.0, 0.05, &rng);
  BundleProblem problem = scene.truth;
  problem.keyframes[0].fixed = true;  // gauge: the first keyframe and one more (scale)
  problem.keyframes[1].fixed = true;
  PerturbClient(&problem, 0.01, 0.1, 0.15, &rng);
  const double initial_error = MaxCenterError(problem, scene.truth);
  BundleOptions options;
  const BundleReport report = SolveBundleAdjustment(options, &problem);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_LT(report.final_cost, report.initial_cost);
  EXPECT_GT(report.num_iterations, 0);
  EXPECT_GE(report.time_ms, 0.0);
  EXPECT_LT(MaxCenterError(problem, scene.truth), 0.03) << "seed " << seed << ", initial "
                                                        << initial_error;
  EXPECT_LT(MedianPointError(problem, scene.truth), 0.05);
  // X' ends near the hidden point it stands for.
  std::vector<double> restored_errors;
  for (size_t k = 0; k < problem.lines.size(); ++k) {
    restored_errors.push_back((problem.lines[k].restored_point - scene.hidden_points[k]).norm());
    // The lines themselves were fixed.
    EXPECT_EQ(problem.lines[k].line.anchor, scene.truth.lines[k].line.anchor);
  }
  std::sort(restored_errors.begin(), restored_errors.end());
  EXPECT_LT(restored_errors[restored_errors.size() / 2], 0.05);
  int wrong = 0, outliers = 0;
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    outliers += scene.observation_is_outlier[i];
    wrong += problem.observations[i].outlier != static_cast<bool>(scene.observation_is_outlier[i]);
  }
  EXPECT_GT(outliers, 50);
  EXPECT_LT(wrong, 0.08 * problem.observations.size()) << "seed " << seed;
  EXPECT_EQ(report.num_outliers, std::count_if(problem.observations.begin(),
                                               problem.observations.end(),
                                               [](const auto& o) { return o.outlier; }));
}

// BundleOptions::should_stop (live local BA, interrupted when the next keyframe is queued): the
// solve stops at the iteration where it is asked to, skips the refine pass, and keeps the best
// state it reached, which is better than the start and not as good as the full solve.
TEST(SolveBundleAdjustment, StopsWhenAskedAndKeepsTheStateReached) {
  std::mt19937 rng(31);
  const Scene scene = MakeScene(10, 600, 0.3, 1.0, 0.05, &rng);
  BundleProblem start = scene.truth;
  start.keyframes[0].fixed = true;
  start.keyframes[1].fixed = true;
  PerturbClient(&start, 0.01, 0.1, 0.15, &rng);
  const double initial_error = MaxCenterError(start, scene.truth);

  BundleProblem full = start;
  const BundleReport full_report = SolveBundleAdjustment(BundleOptions(), &full);
  ASSERT_TRUE(full_report.success) << full_report.message;
  EXPECT_FALSE(full_report.stopped_early);

  // Asked after two polls: Ceres polls after iteration 0 (the start) and after each iteration.
  BundleProblem stopped = start;
  BundleOptions options;
  int polls = 0;
  options.should_stop = [&polls] { return ++polls >= 3; };
  const BundleReport report = SolveBundleAdjustment(options, &stopped);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_TRUE(report.stopped_early);
  EXPECT_EQ(polls, 3);  // no refine pass after the stop
  EXPECT_LE(report.num_iterations, 3);
  EXPECT_LT(report.num_iterations, full_report.num_iterations);
  EXPECT_LT(report.final_cost, report.initial_cost);
  const double stopped_error = MaxCenterError(stopped, scene.truth);
  EXPECT_LT(stopped_error, initial_error);
  EXPECT_GT(stopped_error, MaxCenterError(full, scene.truth));
  EXPECT_EQ(report.num_outliers, std::count_if(stopped.observations.begin(),
                                               stopped.observations.end(),
                                               [](const auto& o) { return o.outlier; }));

  // Asked before the first iteration: nothing moves.
  BundleProblem at_once = start;
  options.should_stop = [] { return true; };
  const BundleReport at_once_report = SolveBundleAdjustment(options, &at_once);
  EXPECT_TRUE(at_once_report.stopped_early);
  EXPECT_LT(MaxCenterError(at_once, start), 1e-12);
}

TEST(SolveBundleAdjustment, FixedBlocksDoNotMove) {
  std::mt19937 rng(37);
  Scene scene = MakeScene(5, 200, 0.0, 0.5, 0.0, &rng);
  BundleProblem problem = scene.truth;
  for (BundleKeyframe& keyframe : problem.keyframes) keyframe.fixed = true;
  PerturbClient(&problem, 0.0, 0.0, 0.1, &rng);
  problem.points[0].fixed = true;
  const Eigen::Vector3d fixed_point = problem.points[0].position;
  const Rigid3d pose = problem.keyframes[2].cam_from_world;
  const double initial_error = MedianPointError(problem, scene.truth);
  const BundleReport report = SolveBundleAdjustment(BundleOptions(), &problem);
  ASSERT_TRUE(report.success);
  EXPECT_EQ(problem.points[0].position, fixed_point);
  EXPECT_LT((problem.keyframes[2].cam_from_world.translation - pose.translation).norm(), 1e-12);
  // Structure-only BA with exact poses: points back to within triangulation noise (0.5 px at
  // up to 14 m depth over a 3.2 m baseline: a few cm).
  EXPECT_LT(MedianPointError(problem, scene.truth), 0.3 * initial_error);
  EXPECT_LT(MedianPointError(problem, scene.truth), 0.06);
}

// Monocular gauge: one fixed keyframe leaves the scale free. The anchor goes from it to the
// free keyframe farthest away, and is not needed when a second fixed keyframe, a fixed point or
// a line-cloud term carries the scale.
TEST(ChooseScaleAnchor, OnlyWhenOneFixedKeyframeHoldsTheGauge) {
  std::mt19937 rng(41);
  Scene scene = MakeScene(6, 200, 0.0, 0.5, 0.0, &rng);
  BundleProblem problem = scene.truth;
  EXPECT_EQ(ChooseScaleAnchor(problem).keyframe, -1) << "nothing fixed: no anchor to hold";
  problem.keyframes[2].fixed = true;
  const BundleScaleAnchor anchor = ChooseScaleAnchor(problem);
  EXPECT_EQ(anchor.fixed_keyframe, 2);
  EXPECT_EQ(anchor.keyframe, 5);  // 2.4 m away; keyframe 0 is 1.6 m away
  EXPECT_NEAR(anchor.distance,
              (problem.keyframes[5].cam_from_world.Center() -
               problem.keyframes[2].cam_from_world.Center()).norm(),
              1e-12);

  BundleProblem two_fixed = problem;
  two_fixed.keyframes[4].fixed = true;
  EXPECT_EQ(ChooseScaleAnchor(two_fixed).keyframe, -1);
  // A fixed keyframe whose observations are all outliers holds nothing.
  for (BundleObservation& obs : two_fixed.observations) obs.outlier |= obs.keyframe == 4;
  EXPECT_EQ(ChooseScaleAnchor(two_fixed).keyframe, 5);

  BundleProblem fixed_point = problem;
  fixed_point.points[fixed_point.observations.front().landmark].fixed = true;
  EXPECT_EQ(ChooseScaleAnchor(fixed_point).keyframe, -1);

  Scene with_lines = MakeScene(6, 200, 0.3, 0.5, 0.0, &rng);
  with_lines.truth.keyframes[2].fixed = true;
  EXPECT_EQ(ChooseScaleAnchor(with_lines.truth).keyframe, -1);
}

// With only the first keyframe fixed, the solution keeps the initial distance to the anchored
// keyframe (the scale) however long Ceres runs, and still recovers the shape: every centre ends
// near the truth scaled about the fixed keyframe by the initial state's scale.
TEST(SolveBundleAdjustment, OneFixedKeyframeKeepsTheInitialScale) {
  std::mt19937 rng(43);
  Scene scene = MakeScene(8, 500, 0.0, 0.5, 0.0, &rng);
  BundleProblem problem = scene.truth;
  problem.keyframes[0].fixed = true;
  PerturbClient(&problem, 0.005, 0.05, 0.1, &rng);
  const Eigen::Vector3d origin = problem.keyframes[0].cam_from_world.Center();
  const double initial_distance = (problem.keyframes[7].cam_from_world.Center() - origin).norm();
  BundleOptions options;
  options.max_iterations = 100;
  options.max_refine_iterations = 100;
  options.function_tolerance = 1e-12;
  const BundleReport report = SolveBundleAdjustment(options, &problem);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_EQ(problem.scale_anchor.fixed_keyframe, 0);
  EXPECT_EQ(problem.scale_anchor.keyframe, 7);
  const double final_distance = (problem.keyframes[7].cam_from_world.Center() - origin).norm();
  EXPECT_NEAR(final_distance, initial_distance, 1e-4 * initial_distance);
  const double scale = final_distance /
                       (scene.truth.keyframes[7].cam_from_world.Center() - origin).norm();
  for (size_t i = 1; i < problem.keyframes.size(); ++i) {
    const Eigen::Vector3d expected =
        origin + scale * (scene.truth.keyframes[i].cam_from_world.Center() - origin);
    EXPECT_LT((problem.keyframes[i].cam_from_world.Center() - expected).norm(), 0.02)
        << "keyframe " << i;
  }
}

TEST(SolveBundleAdjustment, GlobalBAWithVirtualObservationsRecoversAPerturbedLineCloud) {
  const unsigned seed = 41;
  std::mt19937 rng(seed);
  Scene scene = MakeScene(8, 500, 0.5, 0.5, 0.0, &rng);
  BundleProblem problem = scene.truth;
  // Server keyframes: an earlier pass over the same street, offset sideways and up.
  for (int s = 0; s < 6; ++s) {
    BundleServerKeyframe server;
    server.id = 500 + s;
    const Rigid3d world_from_cam(ExpSO3(Eigen::Vector3d(0.05, -0.1 + 0.04 * s, 0.0)),
                                 Eigen::Vector3d(-1.0 + 1.4 * s, -0.8, 0.5));
    server.cam_from_world = world_from_cam.Inverse();
    problem.server_keyframes.push_back(server);
  }
  std::vector<std::pair<int, int>> pairs;
  for (int s = 0; s < 6; ++s) {
    for (int l = 0; l < static_cast<int>(problem.lines.size()); ++l) pairs.emplace_back(s, l);
  }
  MakeVirtualObservations(pairs, &problem);  // n_v from the true, consistent server map
  ASSERT_GT(problem.virtual_observations.size(), 1000u);
  const BundleProblem truth = problem;

  // Perturb everything but the gauge: server poses, lines (anchor and direction), client poses,
  // points and X'.
  problem.keyframes[0].fixed = true;
  problem.keyframes[1].fixed = true;
  PerturbClient(&problem, 0.005, 0.05, 0.1, &rng);
  for (BundleServerKeyframe& server : problem.server_keyframes) {
    server.cam_from_world = RandomPose(&rng, 0.01, 0.1) * server.cam_from_world;
  }
  std::normal_distribution<double> noise(0.0, 1.0);
  auto line_error = [&](const BundleProblem& p) {
    double sum = 0.0;
    for (size_t k = 0; k < p.lines.size(); ++k) {
      const Line3d& line = p.lines[k].line;
      const double angle =
          std::acos(std::min(1.0, std::abs(line.direction.dot(truth.lines[k].line.direction))));
      sum += line.Distance(scene.hidden_points[k]) + angle;
    }
    return sum / p.lines.size();
  };
  for (BundleLine& line : problem.lines) {
    line.fixed = false;
    line.line = RetractLine(line.line, Eigen::Vector4d(0.05 * noise(rng), 0.05 * noise(rng),
                                                       0.02 * noise(rng), 0.02 * noise(rng)));
  }
  auto server_error = [&](const BundleProblem& p) {
    double error = 0.0;
    for (size_t s = 0; s < p.server_keyframes.size(); ++s) {
      error = std::max(error, (p.server_keyframes[s].cam_from_world.Center() -
                               truth.server_keyframes[s].cam_from_world.Center()).norm());
    }
    return error;
  };
  const double line_error_before = line_error(problem);
  const double server_error_before = server_error(problem);

  BundleOptions options;
  options.max_iterations = 30;
  options.max_refine_iterations = 10;
  const BundleReport report = SolveBundleAdjustment(options, &problem);
  ASSERT_TRUE(report.success) << report.message;
  const double line_error_after = line_error(problem);
  const double server_error_after = server_error(problem);
  EXPECT_LT(line_error_after, 0.2 * line_error_before)
      << "seed " << seed << ": " << line_error_before << " -> " << line_error_after;
  EXPECT_LT(server_error_after, 0.2 * server_error_before)
      << server_error_before << " -> " << server_error_after;
  EXPECT_LT(MaxCenterError(problem, truth), 0.03);
  for (const BundleLine& line : problem.lines) EXPECT_NEAR(line.line.direction.norm(), 1.0, 1e-12);
}

TEST(SolveBundleAdjustment, IsDeterministic) {
  std::mt19937 rng(47);
  Scene scene = MakeScene(6, 300, 0.3, 1.0, 0.05, &rng);
  BundleProblem problem = scene.truth;
  problem.keyframes[0].fixed = true;
  problem.keyframes[1].fixed = true;
  PerturbClient(&problem, 0.01, 0.1, 0.1, &rng);
  BundleProblem a = problem, b = problem;
  SolveBundleAdjustment(BundleOptions(), &a);
  SolveBundleAdjustment(BundleOptions(), &b);
  for (size_t i = 0; i < a.keyframes.size(); ++i) {
    EXPECT_EQ(a.keyframes[i].cam_from_world.translation, b.keyframes[i].cam_from_world.translation);
  }
  for (size_t i = 0; i < a.points.size(); ++i) EXPECT_EQ(a.points[i].position, b.points[i].position);
  for (size_t i = 0; i < a.observations.size(); ++i) {
    EXPECT_EQ(a.observations[i].outlier, b.observations[i].outlier);
  }
}

TEST(BundleProblem, ProblemNamesTheBadEntry) {
  std::mt19937 rng(43);
  Scene scene = MakeScene(3, 50, 0.3, 0.5, 0.0, &rng);
  BundleProblem problem = scene.truth;
  EXPECT_EQ(problem.Problem(), "");
  problem.observations[3].keyframe = 40;
  EXPECT_EQ(problem.Problem(), "observations[3]: keyframe 40 out of range");
  problem = scene.truth;
  problem.keyframes[1].camera = nullptr;
  EXPECT_EQ(problem.Problem(), "keyframes[1]: no camera");
  problem = scene.truth;
  problem.lines[0].line.direction = Eigen::Vector3d(0, 0, 2);
  EXPECT_EQ(problem.Problem(), "lines[0]: direction norm 2");
  EXPECT_THROW(SolveBundleAdjustment(BundleOptions(), &problem), std::logic_error);
}

TEST(SolveBundleAdjustment, EmptyProblemSucceedsWithoutIterations) {
  BundleProblem problem;
  const BundleReport report = SolveBundleAdjustment(BundleOptions(), &problem);
  EXPECT_TRUE(report.success);
  EXPECT_EQ(report.num_iterations, 0);
}

}  // namespace
}  // namespace lcv::slam
