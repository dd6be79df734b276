#include "slam/optimize/motion_only_ba.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/line3.h"
#include "slam/geometry/so3.h"
#include "slam/optimize/residuals.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::AllCameraModels;
using testing::RandomPose;
using testing::TestCameraParams;

struct SyntheticFrame {
  Rigid3d true_cam_from_world;
  Rigid3d initial_cam_from_world;
  std::vector<MotionOnlyPointTerm> points;
  std::vector<MotionOnlyLineTerm> lines;
  std::vector<bool> point_is_outlier;
  std::vector<bool> line_is_outlier;
};

// A direction the camera images well (cone around +z; all around for equirectangular).
Eigen::Vector3d VisibleBearing(CameraModel model, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  if (model == CameraModel::kEquirectangular) {
    const double lon = 3.0 * uniform(*rng);
    const double lat = 1.0 * uniform(*rng);
    return Eigen::Vector3d(std::cos(lat) * std::sin(lon), std::sin(lat),
                           std::cos(lat) * std::cos(lon));
  }
  const double spread = model == CameraModel::kFisheye ? 1.2 : 0.6;
  return Eigen::Vector3d(spread * uniform(*rng), 0.5 * spread * uniform(*rng), 1.0).normalized();
}

// num_points point terms and num_lines line terms seen by a camera at a random pose, pixel noise
// noise_px, a fraction outlier_ratio of the observations replaced by random pixels. Lines have
// random directions through the hidden points, anchors up to 2 m away, Sigma_X = 0.05^2 I, and
// X' starts at the midpoint between the observation's ray (at initial_pose) and the line.
// initial_cam_from_world is the truth perturbed by initial_rad and initial_m.
SyntheticFrame MakeFrame(const Camera& camera, int num_points, int num_lines, double noise_px,
                         double outlier_ratio, double initial_rad, double initial_m,
                         std::mt19937* rng) {
  SyntheticFrame frame;
  frame.true_cam_from_world = RandomPose(rng, 0.5, 2.0);
  frame.initial_cam_from_world = RandomPose(rng, initial_rad, initial_m) * frame.true_cam_from_world;
  const Rigid3d& initial_pose = frame.initial_cam_from_world;
  const Rigid3d world_from_cam = frame.true_cam_from_world.Inverse();
  std::normal_distribution<double> noise(0.0, noise_px);
  std::uniform_real_distribution<double> depth(3.0, 15.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto observe = [&](const Eigen::Vector3d& p_in_world, bool outlier) {
    if (outlier) {
      return Eigen::Vector2d(unit(*rng) * (camera.cols() - 1), unit(*rng) * (camera.rows() - 1));
    }
    return Eigen::Vector2d(*camera.Project(frame.true_cam_from_world * p_in_world) +
                           Eigen::Vector2d(noise(*rng), noise(*rng)));
  };
  for (int i = 0; i < num_points; ++i) {
    MotionOnlyPointTerm term;
    term.p_in_world = world_from_cam * (depth(*rng) * VisibleBearing(camera.model(), rng));
    const bool outlier = unit(*rng) < outlier_ratio;
    term.observed_px = observe(term.p_in_world, outlier);
    frame.points.push_back(term);
    frame.point_is_outlier.push_back(outlier);
  }
  const Eigen::Matrix3d point_covariance = 0.05 * 0.05 * Eigen::Matrix3d::Identity();
  for (int i = 0; i < num_lines; ++i) {
    const Eigen::Vector3d hidden = world_from_cam * (depth(*rng) * VisibleBearing(camera.model(), rng));
    const Eigen::Vector3d direction = UniformUnitVector(unit(*rng), unit(*rng));
    MotionOnlyLineTerm term;
    term.line = Line3d(hidden + (4.0 * unit(*rng) - 2.0) * direction, direction);
    term.sqrt_information = SqrtInformation(LineInformation(direction, point_covariance));
    const bool outlier = unit(*rng) < outlier_ratio;
    term.observed_px = observe(hidden, outlier);
    const Eigen::Vector3d bearing = *camera.Unproject(term.observed_px);
    const Rigid3d initial_world_from_cam = initial_pose.Inverse();
    const Line3d ray(initial_world_from_cam.translation, initial_world_from_cam.rotation * bearing);
    const auto closest = ClosestPointsBetweenLines(ray, term.line);
    term.restored_point = closest ? Eigen::Vector3d(0.5 * (ray.PointAt(closest->s_a) +
                                                           term.line.PointAt(closest->s_b)))
                                  : term.line.anchor;
    frame.lines.push_back(term);
    frame.line_is_outlier.push_back(outlier);
  }
  return frame;
}

double RotationError(const Rigid3d& a, const Rigid3d& b) {
  return AngularDistance(a.rotation, b.rotation);
}
double CenterError(const Rigid3d& a, const Rigid3d& b) { return (a.Center() - b.Center()).norm(); }

struct FlagStats {
  int wrong = 0;
  int outliers = 0;
};
template <typename Term>
FlagStats CompareFlags(const std::vector<Term>& terms, const std::vector<bool>& is_outlier) {
  FlagStats stats;
  for (size_t i = 0; i < terms.size(); ++i) {
    stats.outliers += is_outlier[i];
    stats.wrong += terms[i].inlier == is_outlier[i];
  }
  return stats;
}

TEST(MotionOnlyBA, RecoversPoseAndOutlierFlagsWith30PercentOutliersForEveryModel) {
  for (const CameraModel model : AllCameraModels()) {
    SCOPED_TRACE(CameraModelName(model));
    const unsigned seed = 101;
    std::mt19937 rng(seed);
    const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(model));
    // Same true pose for the initial-guess draw: generate, then perturb.
    SyntheticFrame frame = MakeFrame(*camera, 300, 0, 1.0, 0.3, 0.03, 0.15, &rng);
    Rigid3d pose = frame.initial_cam_from_world;
    MotionOnlyBA solver;
    const MotionOnlyBAReport report = solver.Solve(*camera, &pose, &frame.points, &frame.lines);
    EXPECT_TRUE(report.success) << "seed " << seed;
    EXPECT_LT(RotationError(pose, frame.true_cam_from_world), 2e-3) << "seed " << seed;
    EXPECT_LT(CenterError(pose, frame.true_cam_from_world), 2e-2) << "seed " << seed;
    const FlagStats stats = CompareFlags(frame.points, frame.point_is_outlier);
    EXPECT_GT(stats.outliers, 60);
    // 95% chi^2 test: about 5% of the true inliers fall beyond the threshold by chance.
    EXPECT_LE(stats.wrong, 0.09 * 300) << "seed " << seed;
    EXPECT_LT(report.final_cost, report.initial_cost);
    EXPECT_EQ(report.num_point_inliers + stats.wrong >= 300 - stats.outliers, true);
  }
}

TEST(MotionOnlyBA, AgreesWithCeresTwinOnInlierData) {
  for (const CameraModel model : AllCameraModels()) {
    SCOPED_TRACE(CameraModelName(model));
    std::mt19937 rng(202);
    const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(model));
    SyntheticFrame frame = MakeFrame(*camera, 80, 60, 0.7, 0.0, 0.02, 0.1, &rng);
    const Rigid3d initial = frame.initial_cam_from_world;
    Rigid3d hand_pose = initial;
    Rigid3d ceres_pose = initial;
    std::vector<MotionOnlyPointTerm> hand_points = frame.points, ceres_points = frame.points;
    std::vector<MotionOnlyLineTerm> hand_lines = frame.lines, ceres_lines = frame.lines;
    MotionOnlyBAOptions options;
    options.num_rounds = 1;  // one round: no reclassification, so both optimize the same terms
    options.robust_rounds = 0;
    options.iterations_per_round = 50;
    options.function_tolerance = 1e-15;  // to convergence: X' along a line is weakly conditioned
    MotionOnlyBA solver(options);
    const MotionOnlyBAReport hand = solver.Solve(*camera, &hand_pose, &hand_points, &hand_lines);
    const MotionOnlyBAReport twin =
        SolveMotionOnlyBACeres(options, *camera, &ceres_pose, &ceres_points, &ceres_lines);
    ASSERT_TRUE(hand.success);
    ASSERT_TRUE(twin.success);
    EXPECT_LT(RotationError(hand_pose, ceres_pose), 1e-6);
    EXPECT_LT((hand_pose.translation - ceres_pose.translation).norm(), 1e-6);
    double max_point_difference = 0.0;
    for (size_t i = 0; i < hand_lines.size(); ++i) {
      max_point_difference = std::max(
          max_point_difference,
          (hand_lines[i].restored_point - ceres_lines[i].restored_point).norm());
    }
    EXPECT_LT(max_point_difference, 1e-6);
    EXPECT_NEAR(hand.final_cost, twin.final_cost, 1e-6 * (1.0 + twin.final_cost));
    // And both are near the truth.
    EXPECT_LT(CenterError(hand_pose, frame.true_cam_from_world), 2e-2);
  }
}

TEST(MotionOnlyBA, AgreesWithCeresTwinWithOutliersAndRounds) {
  std::mt19937 rng(303);
  const std::unique_ptr<Camera> camera =
      MakeCamera(TestCameraParams(CameraModel::kPerspective));
  SyntheticFrame frame = MakeFrame(*camera, 200, 100, 1.0, 0.3, 0.02, 0.1, &rng);
  const Rigid3d initial = frame.initial_cam_from_world;
  Rigid3d hand_pose = initial, ceres_pose = initial;
  std::vector<MotionOnlyPointTerm> hand_points = frame.points, ceres_points = frame.points;
  std::vector<MotionOnlyLineTerm> hand_lines = frame.lines, ceres_lines = frame.lines;
  MotionOnlyBAOptions options;
  options.iterations_per_round = 30;  // both converge within each round
  MotionOnlyBA solver(options);
  solver.Solve(*camera, &hand_pose, &hand_points, &hand_lines);
  SolveMotionOnlyBACeres(options, *camera, &ceres_pose, &ceres_points, &ceres_lines);
  EXPECT_LT(RotationError(hand_pose, ceres_pose), 1e-6);
  EXPECT_LT((hand_pose.translation - ceres_pose.translation).norm(), 1e-6);
  for (size_t i = 0; i < hand_points.size(); ++i) {
    EXPECT_EQ(hand_points[i].inlier, ceres_points[i].inlier) << "point " << i;
  }
  for (size_t i = 0; i < hand_lines.size(); ++i) {
    EXPECT_EQ(hand_lines[i].inlier, ceres_lines[i].inlier) << "line " << i;
  }
}

TEST(MotionOnlyBA, LineTermsAloneDetermineThePose) {
  for (const CameraModel model : AllCameraModels()) {
    SCOPED_TRACE(CameraModelName(model));
    std::mt19937 rng(404);
    const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(model));
    SyntheticFrame frame = MakeFrame(*camera, 0, 150, 1.0, 0.2, 0.02, 0.1, &rng);
    Rigid3d pose = frame.initial_cam_from_world;
    MotionOnlyBA solver;
    const MotionOnlyBAReport report = solver.Solve(*camera, &pose, &frame.points, &frame.lines);
    EXPECT_TRUE(report.success);
    EXPECT_LT(RotationError(pose, frame.true_cam_from_world), 5e-3);
    EXPECT_LT(CenterError(pose, frame.true_cam_from_world), 5e-2);
    const FlagStats stats = CompareFlags(frame.lines, frame.line_is_outlier);
    EXPECT_LE(stats.wrong, 0.12 * 150);
    // The restored points of the inliers end near the line and on the observation's ray.
    int checked = 0;
    for (size_t i = 0; i < frame.lines.size(); ++i) {
      if (frame.line_is_outlier[i] || !frame.lines[i].inlier) continue;
      EXPECT_LT(frame.lines[i].line.Distance(frame.lines[i].restored_point), 0.25);
      ++checked;
    }
    EXPECT_GT(checked, 100);
  }
}

TEST(MotionOnlyBA, TooFewTermsFailWithoutMovingThePose) {
  std::mt19937 rng(505);
  const std::unique_ptr<Camera> camera =
      MakeCamera(TestCameraParams(CameraModel::kPerspective));
  MotionOnlyBA solver;
  std::vector<MotionOnlyPointTerm> points;
  std::vector<MotionOnlyLineTerm> lines;
  const Rigid3d start = RandomPose(&rng, 0.3, 1.0);
  Rigid3d pose = start;
  MotionOnlyBAReport report = solver.Solve(*camera, &pose, &points, &lines);
  EXPECT_FALSE(report.success);
  EXPECT_EQ(pose.translation, start.translation);

  // Two points leave the 6-dof pose undetermined.
  SyntheticFrame frame = MakeFrame(*camera, 2, 0, 0.0, 0.0, 0.0, 0.0, &rng);
  pose = frame.true_cam_from_world;
  report = solver.Solve(*camera, &pose, &frame.points, &frame.lines);
  EXPECT_FALSE(report.success);
  EXPECT_TRUE(std::isfinite(pose.translation.norm()));
}

TEST(MotionOnlyBA, ExcludedTermsAreReclassified) {
  std::mt19937 rng(606);
  const std::unique_ptr<Camera> camera =
      MakeCamera(TestCameraParams(CameraModel::kPerspective));
  SyntheticFrame frame = MakeFrame(*camera, 100, 0, 0.5, 0.0, 0.01, 0.05, &rng);
  for (int i = 0; i < 10; ++i) frame.points[i].inlier = false;  // good terms marked out
  Rigid3d pose = frame.initial_cam_from_world;
  MotionOnlyBA solver;
  const MotionOnlyBAReport report = solver.Solve(*camera, &pose, &frame.points, &frame.lines);
  EXPECT_TRUE(report.success);
  int recovered = 0;
  for (int i = 0; i < 10; ++i) recovered += frame.points[i].inlier;
  EXPECT_GE(recovered, 8);
}

// The solver keeps buffers between calls: a reused solver must give bit-identical results to a
// fresh one, whatever it solved before (regression runs rely on determinism).
TEST(MotionOnlyBA, ReusedSolverIsDeterministicAndKeepsNoState) {
  std::mt19937 rng(707);
  const std::unique_ptr<Camera> camera =
      MakeCamera(TestCameraParams(CameraModel::kFisheye));
  const SyntheticFrame big = MakeFrame(*camera, 400, 200, 1.0, 0.2, 0.02, 0.1, &rng);
  const SyntheticFrame small = MakeFrame(*camera, 60, 30, 1.0, 0.2, 0.02, 0.1, &rng);
  MotionOnlyBA reused;
  {
    SyntheticFrame warm = big;
    Rigid3d pose = warm.initial_cam_from_world;
    reused.Solve(*camera, &pose, &warm.points, &warm.lines);
  }
  SyntheticFrame a = small, b = small;
  Rigid3d pose_a = small.initial_cam_from_world, pose_b = small.initial_cam_from_world;
  reused.Solve(*camera, &pose_a, &a.points, &a.lines);
  MotionOnlyBA fresh;
  fresh.Solve(*camera, &pose_b, &b.points, &b.lines);
  EXPECT_EQ(pose_a.translation, pose_b.translation);
  EXPECT_EQ(pose_a.rotation.coeffs(), pose_b.rotation.coeffs());
  for (size_t i = 0; i < a.lines.size(); ++i) {
    EXPECT_EQ(a.lines[i].restored_point, b.lines[i].restored_point);
    EXPECT_EQ(a.lines[i].inlier, b.lines[i].inlier);
  }
  for (size_t i = 0; i < a.points.size(); ++i) EXPECT_EQ(a.points[i].inlier, b.points[i].inlier);
}

TEST(InitialRestoredPoint, MidpointBetweenRayAndLineWithFallbacks) {
  const Rigid3d cam_from_world(ExpSO3(Eigen::Vector3d(0.1, 0.2, -0.1)),
                               Eigen::Vector3d(0.3, -0.2, 1.0));
  const Rigid3d world_from_cam = cam_from_world.Inverse();
  const Eigen::Vector3d x = world_from_cam * Eigen::Vector3d(0.5, -0.3, 6.0);
  const Eigen::Vector3d bearing = (cam_from_world * x).normalized();
  // A line through x: the midpoint is x itself.
  const Line3d through(x + 2.0 * Eigen::Vector3d(0.6, 0.8, 0.0), Eigen::Vector3d(0.6, 0.8, 0.0));
  EXPECT_LT((InitialRestoredPoint(cam_from_world, bearing, through) - x).norm(), 1e-9);
  // A line 0.2 m off the ray, orthogonal to it: the midpoint is 0.1 m from both.
  const Eigen::Vector3d ray_direction = world_from_cam.rotation * bearing;
  const Eigen::Vector3d offset = ray_direction.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d line_direction = ray_direction.cross(offset);
  const Line3d skew(x + 0.2 * offset, line_direction);
  const Eigen::Vector3d mid = InitialRestoredPoint(cam_from_world, bearing, skew);
  EXPECT_NEAR(skew.Distance(mid), 0.1, 1e-9);
  EXPECT_LT((mid - (x + 0.1 * offset)).norm(), 1e-9);
  // Parallel to the ray: the line's point nearest the camera centre.
  const Line3d parallel(x + offset, ray_direction);
  const Eigen::Vector3d fallback = InitialRestoredPoint(cam_from_world, bearing, parallel);
  EXPECT_LT(parallel.Distance(fallback), 1e-9);
  EXPECT_LT((fallback - parallel.Project(world_from_cam.translation)).norm(), 1e-9);
}

TEST(MotionOnlyBAOptions, ProblemNamesTheBadField) {
  MotionOnlyBAOptions options;
  EXPECT_EQ(options.Problem(), "");
  options.num_rounds = 0;
  EXPECT_NE(options.Problem().find("num_rounds"), std::string::npos);
  options = MotionOnlyBAOptions();
  options.line_weight = -1.0;
  EXPECT_NE(options.Problem().find("line_weight"), std::string::npos);
  EXPECT_THROW(MotionOnlyBA{options}, std::logic_error);
}

}  // namespace
}  // namespace lcv::slam
