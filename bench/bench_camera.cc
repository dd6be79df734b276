// Camera model throughput: ns per point for Project (batch, and single with Jacobian) and
// Unproject (batch), per model, on fixed seeded inputs inside each model's valid region.
// Median and p90 of 25 repetitions of 100,000 points. Usage: bench_camera [num_points]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "slam/camera/camera.h"

namespace {

using lcv::slam::Camera;
using lcv::slam::CameraModel;
using lcv::slam::CameraParams;

CameraParams Perspective() {
  CameraParams p;
  p.name = "perspective (EuRoC, k1 k2 p1 p2)";
  p.cols = 752;
  p.rows = 480;
  p.fx = 458.654;
  p.fy = 457.296;
  p.cx = 367.215;
  p.cy = 248.375;
  p.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0};
  return p;
}

CameraParams Fisheye() {
  CameraParams p;
  p.name = "fisheye (TUM-VI, k1..k4)";
  p.model = CameraModel::kFisheye;
  p.cols = 512;
  p.rows = 512;
  p.fx = 190.978;
  p.fy = 190.973;
  p.cx = 254.932;
  p.cy = 256.897;
  p.distortion = {0.00348239, 0.000715035, -0.00205324, 0.000202937, 0.0};
  return p;
}

CameraParams Equirectangular() {
  CameraParams p;
  p.name = "equirectangular (1920x960)";
  p.model = CameraModel::kEquirectangular;
  p.cols = 1920;
  p.rows = 960;
  return p;
}

struct Stats {
  double median_ns, p90_ns;
};

template <typename Fn>
Stats Measure(int num_points, Fn&& fn) {
  constexpr int kRepetitions = 25;
  std::vector<double> ns_per_point;
  fn();  // warm up
  for (int r = 0; r < kRepetitions; ++r) {
    const auto start = std::chrono::steady_clock::now();
    fn();
    const auto end = std::chrono::steady_clock::now();
    ns_per_point.push_back(std::chrono::duration<double, std::nano>(end - start).count() /
                           num_points);
  }
  std::sort(ns_per_point.begin(), ns_per_point.end());
  return {ns_per_point[kRepetitions / 2], ns_per_point[kRepetitions * 9 / 10]};
}

}  // namespace

int main(int argc, char** argv) {
  const int num_points = argc > 1 ? std::max(1000, std::atoi(argv[1])) : 100000;
  std::printf("%-36s %22s %22s %22s\n", "model", "ProjectBatch ns/pt", "Project+J ns/pt",
              "UnprojectBatch ns/pt");
  std::printf("%-36s %22s %22s %22s\n", "", "median (p90)", "median (p90)", "median (p90)");
  for (const CameraParams& params : {Perspective(), Fisheye(), Equirectangular()}) {
    const std::unique_ptr<Camera> camera = lcv::slam::MakeCamera(params);
    // Inputs: pixels uniform in the image where the model is defined, and their bearings at
    // random depths.
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> u(0.0, params.cols - 1.0), v(0.0, params.rows - 1.0);
    std::uniform_real_distribution<double> depth(0.5, 30.0);
    std::vector<Eigen::Vector2d> pixels;
    std::vector<Eigen::Vector3d> points;
    while (static_cast<int>(pixels.size()) < num_points) {
      const Eigen::Vector2d px(u(rng), v(rng));
      const auto bearing = camera->Unproject(px);
      if (!bearing) continue;  // fisheye corners beyond the valid angle
      pixels.push_back(px);
      points.push_back(depth(rng) * *bearing);
    }
    std::vector<Eigen::Vector2d> projected(num_points);
    std::vector<Eigen::Vector3d> bearings(num_points);
    std::vector<unsigned char> valid(num_points);
    double sink = 0.0;

    const Stats project = Measure(num_points, [&] {
      camera->ProjectBatch(points.data(), num_points, projected.data(), valid.data());
      sink += projected[num_points / 2].x();
    });
    const Stats project_jacobian = Measure(num_points, [&] {
      Eigen::Matrix<double, 2, 3> J;
      for (int i = 0; i < num_points; ++i) {
        const auto px = camera->Project(points[i], &J);
        if (px) sink += px->x() + J(0, 0);
      }
    });
    const Stats unproject = Measure(num_points, [&] {
      camera->UnprojectBatch(pixels.data(), num_points, bearings.data(), valid.data());
      sink += bearings[num_points / 2].z();
    });
    std::printf("%-36s %13.1f (%5.1f) %14.1f (%5.1f) %14.1f (%5.1f)\n", params.name.c_str(),
                project.median_ns, project.p90_ns, project_jacobian.median_ns,
                project_jacobian.p90_ns, unproject.median_ns, unproject.p90_ns);
    if (sink == 42.0) std::printf(" ");  // keeps the work observable
  }
  return 0;
}
