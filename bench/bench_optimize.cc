// Benchmarks of slam/optimize on fixed synthetic problems (seeded): per-call time (median, p90)
// of the hand-written motion-only BA against its Ceres twin, the local BA with Ceres, and the
// effect of the line-term weight w_L on the motion-only pose error.
//
//   build/bench_optimize [--repeats N]
//
// Single thread; times are the thread's CPU time (the machine is shared). Prints one table on
// stdout; nothing is written.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <random>
#include <string>

#include <glog/logging.h>
#include <vector>

#include "bench/thread_cpu_clock.h"
#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/so3.h"
#include "slam/optimize/bundle_adjustment.h"
#include "slam/optimize/motion_only_ba.h"
#include "slam/optimize/residuals.h"

namespace {

using namespace lcv::slam;
using lcv::bench::ThreadCpuMs;

CameraParams Perspective640x360() {
  CameraParams params;
  params.model = CameraModel::kPerspective;
  params.cols = 640;
  params.rows = 360;
  params.fx = params.fy = 450.0;
  params.cx = 319.5;
  params.cy = 179.5;
  return params;
}

// The 360-degree clients' camera (lcv synth's equirectangular sequences are 640x320).
CameraParams Equirectangular640x320() {
  CameraParams params;
  params.model = CameraModel::kEquirectangular;
  params.cols = 640;
  params.rows = 320;
  return params;
}

Rigid3d RandomPose(std::mt19937* rng, double rotation_rad, double translation) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d omega(normal(*rng), normal(*rng), normal(*rng));
  const Eigen::Vector3d t(normal(*rng), normal(*rng), normal(*rng));
  return Rigid3d(ExpSO3(rotation_rad * omega.normalized()), translation * t);
}

struct Frame {
  Rigid3d truth;
  Rigid3d initial;
  std::vector<MotionOnlyPointTerm> points;
  std::vector<MotionOnlyLineTerm> lines;
};

// num_points / num_lines terms, 1 px noise, 10% outliers, lines through X + N(0, 0.05^2 I), initial pose off by 0.02 rad, 0.1 m
// (a constant-velocity prediction's typical error); X' starts at the ray-line midpoint.
Frame MakeFrame(const Camera& camera, int num_points, int num_lines, std::mt19937* rng) {
  Frame frame;
  frame.truth = RandomPose(rng, 0.5, 2.0);
  frame.initial = RandomPose(rng, 0.02, 0.1) * frame.truth;
  const Rigid3d world_from_cam = frame.truth.Inverse();
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  auto hidden_point = [&]() {
    const Eigen::Vector2d px(unit(*rng) * (camera.cols() - 1), unit(*rng) * (camera.rows() - 1));
    return Eigen::Vector3d(world_from_cam * ((3.0 + 12.0 * unit(*rng)) * *camera.Unproject(px)));
  };
  auto observe = [&](const Eigen::Vector3d& x) {
    if (unit(*rng) < 0.1) {
      return Eigen::Vector2d(unit(*rng) * (camera.cols() - 1), unit(*rng) * (camera.rows() - 1));
    }
    return Eigen::Vector2d(*camera.Project(frame.truth * x) +
                           Eigen::Vector2d(noise(*rng), noise(*rng)));
  };
  for (int i = 0; i < num_points; ++i) {
    MotionOnlyPointTerm term;
    term.p_in_world = hidden_point();
    term.observed_px = observe(term.p_in_world);
    frame.points.push_back(term);
  }
  const Eigen::Matrix3d covariance = 0.05 * 0.05 * Eigen::Matrix3d::Identity();
  const Rigid3d initial_world_from_cam = frame.initial.Inverse();
  for (int i = 0; i < num_lines; ++i) {
    const Eigen::Vector3d x = hidden_point();
    const Eigen::Vector3d d = UniformUnitVector(unit(*rng), unit(*rng));
    MotionOnlyLineTerm term;
    // The published line passes through the server's estimate of X, off by its covariance
    // (0.05 m per axis): the line term is as noisy as its information says.
    const Eigen::Vector3d x_estimate =
        x + 0.05 * Eigen::Vector3d(noise(*rng), noise(*rng), noise(*rng));
    term.line = Line3d(x_estimate + (4.0 * unit(*rng) - 2.0) * d, d);
    term.sqrt_information = SqrtInformation(LineInformation(d, covariance));
    term.observed_px = observe(x);
    const Line3d ray(initial_world_from_cam.translation,
                     initial_world_from_cam.rotation * *camera.Unproject(term.observed_px));
    const auto closest = ClosestPointsBetweenLines(ray, term.line);
    term.restored_point =
        closest ? Eigen::Vector3d(0.5 * (ray.PointAt(closest->s_a) +
                                         term.line.PointAt(closest->s_b)))
                : term.line.anchor;
    frame.lines.push_back(term);
  }
  return frame;
}

struct Stats {
  double median = 0.0;
  double p90 = 0.0;
};
Stats Summarize(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  Stats stats;
  if (values.empty()) return stats;
  stats.median = values[values.size() / 2];
  stats.p90 = values[std::min(values.size() - 1, values.size() * 9 / 10)];
  return stats;
}

double Milliseconds(double start_ms) { return ThreadCpuMs() - start_ms; }

void BenchMotionOnly(const Camera& camera, int num_points, int num_lines, int repeats,
                     bool with_ceres = true) {
  std::mt19937 rng(1234 + num_points + 7 * num_lines);
  std::vector<Frame> frames;
  for (int i = 0; i < repeats; ++i) frames.push_back(MakeFrame(camera, num_points, num_lines, &rng));
  MotionOnlyBA solver;
  std::vector<double> hand_ms, ceres_ms, hand_error_m, ceres_error_m;
  for (const Frame& frame : frames) {
    Frame hand = frame;
    Rigid3d pose = frame.initial;
    double start = ThreadCpuMs();
    solver.Solve(camera, &pose, &hand.points, &hand.lines);
    hand_ms.push_back(Milliseconds(start));
    hand_error_m.push_back((pose.Center() - frame.truth.Center()).norm());

    if (!with_ceres) continue;
    Frame twin = frame;
    Rigid3d ceres_pose = frame.initial;
    start = ThreadCpuMs();
    SolveMotionOnlyBACeres(solver.options(), camera, &ceres_pose, &twin.points, &twin.lines);
    ceres_ms.push_back(Milliseconds(start));
    ceres_error_m.push_back((ceres_pose.Center() - frame.truth.Center()).norm());
  }
  const Stats hand = Summarize(hand_ms), twin = Summarize(ceres_ms);
  std::printf("motion-only BA %4d points %4d lines | hand LM %6.3f / %6.3f ms | Ceres twin %7.3f / "
              "%7.3f ms | centre error median hand %.4f m, Ceres %.4f m\n",
              num_points, num_lines, hand.median, hand.p90, twin.median, twin.p90,
              Summarize(hand_error_m).median, Summarize(ceres_error_m).median);
}

void BenchLineWeight(const Camera& camera, int repeats) {
  std::mt19937 rng(99);
  std::vector<Frame> frames;
  for (int i = 0; i < repeats; ++i) frames.push_back(MakeFrame(camera, 0, 300, &rng));
  for (const double weight : {0.01, 0.1, 1.0, 10.0, 100.0}) {
    MotionOnlyBAOptions options;
    options.line_weight = weight;
    MotionOnlyBA solver(options);
    std::vector<double> error_m, error_deg, ms, inliers;
    for (const Frame& frame : frames) {
      Frame copy = frame;
      Rigid3d pose = frame.initial;
      const double start = ThreadCpuMs();
      const MotionOnlyBAReport report = solver.Solve(camera, &pose, &copy.points, &copy.lines);
      ms.push_back(Milliseconds(start));
      error_m.push_back((pose.Center() - frame.truth.Center()).norm());
      error_deg.push_back(AngularDistance(pose.rotation, frame.truth.rotation) * 180.0 / M_PI);
      inliers.push_back(report.num_line_inliers);
    }
    std::printf("line weight w_L %6.2f (300 lines, 10%% outliers) | centre error median %.4f m "
                "p90 %.4f m | rotation median %.4f deg | line inliers median %.0f | %6.3f ms\n",
                weight, Summarize(error_m).median, Summarize(error_m).p90,
                Summarize(error_deg).median, Summarize(inliers).median, Summarize(ms).median);
  }
}

void BenchLocalBA(const Camera& camera, int num_keyframes, int num_points, int repeats) {
  std::vector<double> ms, iterations;
  std::mt19937 rng(4321);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int r = 0; r < repeats; ++r) {
    BundleProblem problem;
    std::vector<Rigid3d> truth;
    for (int i = 0; i < num_keyframes; ++i) {
      const Rigid3d world_from_cam(ExpSO3(Eigen::Vector3d(0.0, 0.02 * i, 0.0)),
                                   Eigen::Vector3d(0.7 * i, 0.0, 0.0));
      truth.push_back(world_from_cam.Inverse());
      BundleKeyframe keyframe;
      keyframe.cam_from_world = i < 2 ? truth.back() : RandomPose(&rng, 0.005, 0.05) * truth.back();
      keyframe.camera = &camera;
      keyframe.fixed = i < 2;
      problem.keyframes.push_back(keyframe);
    }
    while (static_cast<int>(problem.points.size()) < num_points) {
      const Eigen::Vector3d x(-4.0 + (0.7 * num_keyframes + 8.0) * unit(rng),
                              -3.0 + 6.0 * unit(rng), 5.0 + 10.0 * unit(rng));
      const int index = static_cast<int>(problem.points.size());
      int seen = 0;
      for (int i = 0; i < num_keyframes; ++i) {
        const auto px = camera.Project(truth[i] * x);
        if (!px || !camera.InImage(*px)) continue;
        BundleObservation obs;
        obs.keyframe = i;
        obs.landmark = index;
        obs.observed_px = unit(rng) < 0.05
                              ? Eigen::Vector2d(639.0 * unit(rng), 359.0 * unit(rng))
                              : Eigen::Vector2d(*px + Eigen::Vector2d(noise(rng), noise(rng)));
        problem.observations.push_back(obs);
        ++seen;
      }
      if (seen < 2) {
        problem.observations.resize(problem.observations.size() - seen);
        continue;
      }
      BundlePoint point;
      point.position = x + 0.05 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      problem.points.push_back(point);
    }
    const double start = ThreadCpuMs();
    const BundleReport report = SolveBundleAdjustment(BundleOptions(), &problem);
    ms.push_back(Milliseconds(start));
    iterations.push_back(report.num_iterations);
    if (r == 0) {
      std::fprintf(stderr, "local BA: %zu observations, %s\n", problem.observations.size(),
                   report.message.c_str());
    }
  }
  const Stats stats = Summarize(ms);
  std::printf("local BA %d keyframes %d points (Ceres, 10 + 10 iterations, 1 thread) | %7.2f / "
              "%7.2f ms | iterations median %.0f\n",
              num_keyframes, num_points, stats.median, stats.p90, Summarize(iterations).median);
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 50;
  bool equirectangular_only = false;  // for profiling the 360-degree clients' solve alone
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (std::strcmp(argv[i], "--equirectangular-only") == 0) {
      equirectangular_only = true;
    } else {
      std::fprintf(stderr, "usage: %s [--repeats N] [--equirectangular-only]\n", argv[0]);
      return 2;
    }
  }
  // Ceres logs a warning for every rejected step of the twin; keep stdout/stderr readable.
  google::InitGoogleLogging(argv[0]);
  FLAGS_minloglevel = 2;
  const std::unique_ptr<Camera> camera = MakeCamera(Perspective640x360());
  std::printf("slam/optimize benchmarks, %d repeats, times median / p90\n", repeats);
  const std::unique_ptr<Camera> equirectangular = MakeCamera(Equirectangular640x320());
  if (equirectangular_only) {
    BenchMotionOnly(*equirectangular, 600, 15, repeats, /*with_ceres=*/false);
    return 0;
  }
  BenchMotionOnly(*camera, 300, 0, repeats);
  BenchMotionOnly(*camera, 1000, 0, repeats);
  BenchMotionOnly(*camera, 0, 300, repeats);
  BenchMotionOnly(*camera, 300, 300, repeats);
  BenchLineWeight(*camera, repeats);
  // The equirectangular line client's solve (about 600 points and 15 lines a frame when it
  // makes keyframes densely, docs/benchmarks-lcvslam.md) and the point client's (400 points).
  std::printf("equirectangular 640x320:\n");
  BenchMotionOnly(*equirectangular, 400, 0, repeats);
  BenchMotionOnly(*equirectangular, 600, 15, repeats);
  BenchLocalBA(*camera, 10, 2000, std::max(3, repeats / 10));
  return 0;
}
