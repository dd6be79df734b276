// Solver timings (not run by ctest), on seeded synthetic data: minimal solvers per call, the
// RANSAC pipelines per problem, with 30% outliers. Thread CPU time, median and p90.
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
