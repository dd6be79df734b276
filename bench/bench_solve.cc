// Solver timings (not run by ctest), on seeded synthetic data: minimal solvers per call, the
// RANSAC pipelines per problem, with 30-40% outliers. Thread CPU time, median and p90.
//
//   build/bench_solve [REPEATS=200]

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "slam/solve/absolute_pose.h"
#include "slam/solve/essential.h"
#include "slam/solve/p3p.h"
#include "slam/solve/p3l_known_rotation.h"
#include "slam/solve/p4l.h"
#include "slam/solve/p6l.h"
#include "slam/solve/point_line_sim3.h"
#include "slam/solve/ransac.h"
#include "slam/solve/two_view.h"

namespace {

using lcv::slam::Rigid3d;

double NowMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

Eigen::Vector3d RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
}

Eigen::Vector3d Noisy(const Eigen::Vector3d& v, double sigma, std::mt19937_64& rng) {
  std::normal_distribution<double> normal(0.0, sigma);
  return (v.normalized() + Eigen::Vector3d(normal(rng), normal(rng), normal(rng))).normalized();
}

Eigen::Vector3d PointInView(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-0.6, 0.6), depth(4.0, 12.0);
  return Eigen::Vector3d(u(rng), u(rng), 1.0).normalized() * depth(rng);
}

void Print(const char* label, std::vector<double> times, const std::string& extra = "") {
  std::sort(times.begin(), times.end());
  std::printf("%-40s %10.4f %10.4f  %s\n", label, times[times.size() / 2],
              times[std::min(times.size() - 1, times.size() * 9 / 10)], extra.c_str());
}

// "trials T ok K/N": a RANSAC's mean trials over its N runs and the runs that found the truth.
std::string RansacSummary(int total_trials, int num_ok, int runs) {
  return "trials " + std::to_string(total_trials / runs) + " ok " + std::to_string(num_ok) + "/" +
         std::to_string(runs);
}

}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::stoi(argv[1]) : 200;
  std::mt19937_64 rng(1);
  std::printf("%-40s %10s %10s\n", "problem", "median_ms", "p90_ms");

  // P3P, minimal.
  {
    std::vector<double> times;
    int solutions = 0;
    std::vector<Rigid3d> poses;
    for (int r = 0; r < repeats * 10; ++r) {
      const Rigid3d cam_from_world(Eigen::Quaterniond::UnitRandom(), RandomUnit(rng));
      Eigen::Vector3d x[3], X[3];
      for (int i = 0; i < 3; ++i) {
        const Eigen::Vector3d p = PointInView(rng);
        x[i] = p.normalized();
        X[i] = cam_from_world.Inverse() * p;
      }
      const double start = NowMs();
      solutions += lcv::slam::SolveP3P(x, X, &poses);
      times.push_back(NowMs() - start);
    }
    Print("SolveP3P (minimal)", times,
          "mean solutions " + std::to_string(static_cast<double>(solutions) / (repeats * 10)));
  }

  // P4L minimal and the point-line Sim(3) RANSAC pipelines (P4L vs linear 6-correspondence),
  // 200 correspondences, 40% outliers.
  {
    std::vector<double> minimal_times, p4l_times, linear_times;
    int p4l_trials = 0, linear_trials = 0, p4l_ok = 0, linear_ok = 0;
    const int runs = repeats / 4 + 1;
    for (int r = 0; r < runs; ++r) {
      const lcv::slam::Sim3d truth(1.5, Eigen::Quaterniond::UnitRandom(), RandomUnit(rng) * 3.0);
      std::uniform_real_distribution<double> u(-5.0, 5.0);
      std::vector<Eigen::Vector3d> X;
      std::vector<lcv::slam::Line3d> lines;
      for (int i = 0; i < 200; ++i) {
        const Eigen::Vector3d x(u(rng), u(rng), u(rng));
        const Eigen::Vector3d y = i < 80 ? Eigen::Vector3d(u(rng), u(rng), u(rng)) * 3.0
                                         : Eigen::Vector3d(truth * x);
        const Eigen::Vector3d d = RandomUnit(rng);
        X.push_back(x);
        lines.emplace_back(y + u(rng) * d, d);
      }
      std::vector<lcv::slam::Sim3d> solutions;
      for (int k = 0; k < 20; ++k) {
        const double start = NowMs();
        lcv::slam::SolveP4L(X.data() + 80 + 4 * k, lines.data() + 80 + 4 * k, 4, &solutions);
        minimal_times.push_back(NowMs() - start);
      }
      lcv::slam::RansacOptions options;
      options.max_error = 0.05;
      options.random_seed = r;
      options.max_num_trials = 10000;
      double start = NowMs();
      const auto p4l = lcv::slam::Ransac(options, lcv::slam::P4LEstimator(X.data(), lines.data(), 200));
      p4l_times.push_back(NowMs() - start);
      start = NowMs();
      const auto linear =
          lcv::slam::Ransac(options, lcv::slam::Sim3PointLineEstimator(X.data(), lines.data(), 200));
      linear_times.push_back(NowMs() - start);
      p4l_trials += p4l.num_trials;
      linear_trials += linear.num_trials;
      p4l_ok += p4l.success && std::abs(p4l.model.scale - 1.5) < 0.01;
      linear_ok += linear.success && std::abs(linear.model.scale - 1.5) < 0.01;
    }
    Print("SolveP4L (minimal, 4 pairs)", minimal_times);
    Print("RANSAC P4L 200, 40% out", p4l_times, RansacSummary(p4l_trials, p4l_ok, runs));
    Print("RANSAC linear 6-pair Sim3 200, 40% out", linear_times,
          RansacSummary(linear_trials, linear_ok, runs));
  }

  // Camera pose in a line cloud (the live line-cloud check, slam/module/line_cloud_localizer.h):
  // p6L minimal against the centre with the rotation known, and RANSAC of each on 70 bearing-line
  // matches with 45% outliers (as after a camera jump: 39 of 71 right), 1 mrad bearing noise.
  {
    std::vector<double> p6l_minimal, centre_minimal, p6l_ransac, centre_ransac;
    int p6l_trials = 0, centre_trials = 0, p6l_ok = 0, centre_ok = 0;
    const int runs = repeats / 20 + 1;
    std::vector<Rigid3d> poses;
    for (int r = 0; r < runs; ++r) {
      const Rigid3d cam_from_world(Eigen::Quaterniond::UnitRandom(), RandomUnit(rng) * 5.0);
      const Rigid3d world_from_cam = cam_from_world.Inverse();
      std::uniform_real_distribution<double> u(-3.0, 3.0);
      std::vector<Eigen::Vector3d> bearings;
      std::vector<lcv::slam::Line3d> lines;
      for (int i = 0; i < 70; ++i) {
        const Eigen::Vector3d p = PointInView(rng);
        const Eigen::Vector3d d = RandomUnit(rng);
        lines.emplace_back(world_from_cam * p + u(rng) * d, d);
        bearings.push_back(i < 32 ? RandomUnit(rng) : Noisy(p, 1e-3, rng));
      }
      for (int k = 0; k < 4; ++k) {
        double start = NowMs();
        lcv::slam::SolveP6L(bearings.data() + 32 + 6 * k, lines.data() + 32 + 6 * k, 6, &poses);
        p6l_minimal.push_back(NowMs() - start);
        const std::vector<int> sample{32 + 3 * k, 33 + 3 * k, 34 + 3 * k};
        start = NowMs();
        lcv::slam::SolveCentreKnownRotation(cam_from_world.rotation, bearings.data(),
                                            lines.data(), sample);
        centre_minimal.push_back(NowMs() - start);
      }
      lcv::slam::RansacOptions options;
      options.max_error = 3e-3;
      options.random_seed = r;
      options.max_num_trials = 2000;
      options.min_inlier_ratio = 0.0;
      auto centre_error = [&](const Rigid3d& pose) {
        return (pose.Inverse().translation - world_from_cam.translation).norm();
      };
      double start = NowMs();
      const auto p6l = lcv::slam::Ransac(
          options, lcv::slam::P6LEstimator(bearings.data(), lines.data(), 70));
      p6l_ransac.push_back(NowMs() - start);
      start = NowMs();
      const auto centre = lcv::slam::Ransac(
          options, lcv::slam::CentreKnownRotationEstimator(cam_from_world.rotation,
                                                           bearings.data(), lines.data(), 70));
      centre_ransac.push_back(NowMs() - start);
      p6l_trials += p6l.num_trials;
      centre_trials += centre.num_trials;
      p6l_ok += p6l.success && centre_error(p6l.model) < 0.1;
      centre_ok += centre.success && centre_error(centre.model) < 0.1;
    }
    Print("SolveP6L (minimal, 6 pairs)", p6l_minimal);
    Print("SolveCentreKnownRotation (3 pairs)", centre_minimal);
    Print("RANSAC p6L 70, 45% out", p6l_ransac, RansacSummary(p6l_trials, p6l_ok, runs));
    Print("RANSAC centre, rotation known, 70", centre_ransac,
          RansacSummary(centre_trials, centre_ok, runs));
  }

  // Absolute pose RANSAC + refinement: 500 correspondences, 30% outliers.
  {
    std::vector<double> times;
    int successes = 0;
    for (int r = 0; r < repeats; ++r) {
      const Rigid3d cam_from_world(Eigen::Quaterniond::UnitRandom(), RandomUnit(rng));
      std::vector<Eigen::Vector3d> x, X;
      for (int i = 0; i < 500; ++i) {
        const Eigen::Vector3d p = PointInView(rng);
        x.push_back(i < 150 ? Noisy(PointInView(rng), 0.0, rng) : Noisy(p, 1e-3, rng));
        X.push_back(cam_from_world.Inverse() * p);
      }
      lcv::slam::AbsolutePoseOptions options;
      options.ransac.random_seed = r;
      const double start = NowMs();
      successes += lcv::slam::EstimateAbsolutePose(x, X, options).success;
      times.push_back(NowMs() - start);
    }
    Print("EstimateAbsolutePose 500, 30% out", times,
          "success " + std::to_string(successes) + "/" + std::to_string(repeats));
  }

  // Two-view initialization: 1000 correspondences, 30% outliers.
  {
    std::vector<double> times;
    int successes = 0;
    for (int r = 0; r < repeats / 4 + 1; ++r) {
      const Rigid3d cam2_from_cam1(Eigen::Quaterniond(Eigen::AngleAxisd(0.05, RandomUnit(rng))),
                                   Eigen::Vector3d(-0.5, 0.05, 0.1));
      std::vector<Eigen::Vector3d> b1, b2;
      while (b1.size() < 1000) {
        const Eigen::Vector3d p = PointInView(rng);
        const Eigen::Vector3d p2 = cam2_from_cam1 * p;
        if (p2.z() < 1.0) continue;
        const bool outlier = b1.size() < 300;
        b1.push_back(Noisy(p, 1e-3, rng));
        b2.push_back(outlier ? Noisy(PointInView(rng), 0.0, rng) : Noisy(p2, 1e-3, rng));
      }
      lcv::slam::TwoViewOptions options;
      options.random_seed = r;
      const double start = NowMs();
      successes += lcv::slam::EstimateTwoViewGeometry(b1, b2, options).success;
      times.push_back(NowMs() - start);
    }
    Print("EstimateTwoViewGeometry 1000, 30% out", times,
          "success " + std::to_string(successes) + "/" + std::to_string(repeats / 4 + 1));
  }
  return 0;
}
