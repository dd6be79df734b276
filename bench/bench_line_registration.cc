// Line-cloud registration timings and success (not run by ctest): RegisterToLineCloud
// (slam/module/line_cloud_registration.h) on the seeded synthetic scene of the tests (a
// 640x360 pinhole ckf and 3 covisible views, 300 client points, 300 lines of them + 300 lines
// of other points, rotation 40 degrees, scale 2.5) for growing fractions of wrong descriptor
// matches, once against the line cloud of another place, and once with 3000 lines (brute-force
// matching cost), and on the P3P path (server points dominating, server points alone). Thread CPU
// time per registration, median and p90 over the seeds; success rate; rotation (degrees) and scale
// errors of the successes, worst over the seeds.
//
//   build/bench/bench_line_registration [SEEDS=20] [DEPTH_NOISE=0.01] [--refine-scale]
//
// --refine-scale: LineCloudRegistrationOptions::refine_scale_in_ba.
// DEPTH_NOISE: sigma of the client points' error along the ckf's ray, relative to their range.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "bench/thread_cpu_clock.h"
#include "slam/geometry/so3.h"
#include "slam/module/line_cloud_registration.h"
#include "tests/slam/module/registration_scene.h"

namespace {

using namespace lcv::slam;
using lcv::bench::ThreadCpuMs;

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}

CameraParams Pinhole() {
  CameraParams params;
  params.model = CameraModel::kPerspective;
  params.cols = 640;
  params.rows = 360;
  params.fx = params.fy = 450.0;
  params.cx = 319.5;
  params.cy = 179.5;
  return params;
}

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 20;
  const double depth_noise = argc > 2 ? std::atof(argv[2]) : 0.01;
  const bool refine_scale = argc > 3 && std::string(argv[3]) == "--refine-scale";
  const std::unique_ptr<Camera> camera = MakeCamera(Pinhole());
  LineCloudRegistrationOptions options;
  options.refine_scale_in_ba = refine_scale;
  std::printf("%-15s %6s %9s %9s %8s %8s %10s %10s %6s\n", "case", "runs", "median_ms", "p90_ms",
              "success", "trials", "max_rot_deg", "max_scale", "method");
  // kind: 0 lines only, 1 server points dominate (100 lines, 200 server points), 2 server points
  // alone.
  auto run = [&](const char* name, double wrong, bool elsewhere, int other_lines = 300,
                 int kind = 0) {
    std::vector<double> times;
    int successes = 0;
    double trials = 0.0, max_rotation_deg = 0.0, max_scale_error = 0.0;
    std::string method;  // of the last run that got to RANSAC
    for (int seed = 1; seed <= seeds; ++seed) {
      testing::RegistrationSceneOptions scene_options;
      scene_options.wrong_match_ratio = wrong;
      scene_options.num_other_lines = other_lines;
      scene_options.depth_noise_ratio = depth_noise;
      if (kind > 0) {
        scene_options.num_lines_of_points = kind == 1 ? 100 : 0;
        scene_options.num_other_lines = kind == 1 ? 300 : 0;
        scene_options.num_server_points = kind == 1 ? 200 : 300;
        scene_options.num_other_server_points = 300;
      }
      scene_options.seed = seed;
      const testing::RegistrationScene scene = MakeRegistrationScene(*camera, scene_options);
      std::vector<RegistrationLine> lines = scene.lines;
      if (elsewhere) {  // another place whose lines carry the client's descriptors
        scene_options.seed = 1000 + seed;
        lines = MakeRegistrationScene(*camera, scene_options).lines;
        for (size_t j = 0; j < scene.points.size(); ++j) {
          lines[j].descriptor = scene.points[j].descriptor;
        }
      }
      const double start = ThreadCpuMs();
      const LineCloudRegistration result =
          RegisterToLineCloud(scene.views, scene.points, lines, scene.server_points, options);
      times.push_back(ThreadCpuMs() - start);
      trials += result.num_ransac_trials;
      if (!result.method.empty()) method = result.method;
      if (!result.success) continue;
      ++successes;
      max_rotation_deg =
          std::max(max_rotation_deg, AngularDistance(result.server_from_client.rotation,
                                                     scene.server_from_client_true.rotation) *
                                         180.0 / M_PI);
      max_scale_error = std::max(
          max_scale_error,
          std::abs(result.server_from_client.scale / scene.server_from_client_true.scale - 1.0));
    }
    std::printf("%-15s %6d %9.1f %9.1f %7.0f%% %8.0f %10.3f %10.4f %6s\n", name, seeds,
                Percentile(times, 0.5), Percentile(times, 0.9), 100.0 * successes / seeds,
                trials / seeds, max_rotation_deg, max_scale_error, method.c_str());
  };
  run("wrong 0%", 0.0, false);
  run("wrong 30%", 0.3, false);
  run("wrong 50%", 0.5, false);
  run("wrong 70%", 0.7, false);
  run("wrong 90%", 0.9, false);
  run("other place", 0.0, true);
  // Matching cost: 300 client points against 3000 lines (10 candidate server keyframes).
  run("3000 lines 30%", 0.3, false, 2700);
  // P3P: server points dominate (N_PL / N_PP ~ 1/2), and server points alone.
  run("p3p mixed 30%", 0.3, false, 300, 1);
  run("p3p alone 50%", 0.5, false, 0, 2);
  return 0;
}
