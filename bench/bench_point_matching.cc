// Tracking's search of 3D points by projection (slam/match/projection_matcher.h): time per call
// of MatchByProjection with the frame's 32 px KeypointGrid on one thread (search_cell_px 0, the
// search before d301a53), with the grid of free keypoints (8 px cells) on one thread and on two,
// on a synthetic 640x480 pinhole frame (tests/slam/system/synthetic_features.h: a slab of
// points 4-9 m away seen from a pose 2 cm and ~0.2 degrees off, plus clutter keypoints). Two
// searches as tracking runs them: the local map's (10 px windows, ratio 0.8) and the last
// frame's (15 px, ratio 1, orientation check). All three settings must give the same matches;
// the bench says so or exits 1.
// Usage: bench_point_matching [--reps N] [--points N] [--clutter N]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "bench/thread_cpu_clock.h"
#include "slam/match/projection_matcher.h"
#include "tests/slam/match/matcher_test_util.h"

namespace {

using namespace lcv::slam;
using lcv::bench::ThreadCpuMs;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 200, num_points = 2000, clutter = 300;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::printf("usage: bench_point_matching [--reps N] [--points N] [--clutter N]\n");
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "bench_point_matching: %s needs a value\n", arg.c_str());
      return 2;
    }
    const int value = std::atoi(argv[++i]);
    if (arg == "--reps") reps = std::max(1, value);
    else if (arg == "--points") num_points = std::max(1, value);
    else if (arg == "--clutter") clutter = std::max(0, value);
    else {
      std::fprintf(stderr, "bench_point_matching: unknown option %s\n", arg.c_str());
      return 2;
    }
  }
  const auto camera = MakeCamera(testing::SyntheticPinhole());
  const testing::SyntheticScene scene = testing::MakeSlabScene(num_points, -4.0, 4.0, 4.0, 9.0, 7);
  const Rigid3d pose = testing::MakeLateralTrajectory(5, 0.1)[4];
  std::mt19937_64 rng(8);
  testing::ObservationNoise noise;
  noise.clutter = clutter;
  const testing::SyntheticFrame observed = testing::ObserveScene(scene, *camera, pose, noise, &rng);
  const Frame start = testing::MakeFrame(*camera, observed, pose, 1);
  Vector6d delta;
  delta << 0.02, -0.01, 0.005, 0.002, -0.003, 0.001;
  const Rigid3d perturbed = Rigid3d::Exp(delta) * pose;
  std::printf("%d keypoints, %zu candidates, %d reps; median ms per call (wall / this thread's CPU)\n\n",
              start.num_keypoints(), scene.points_in_world.size(), reps);
  std::printf("| search | frame grid, 1 thread | free-keypoint grid, 1 thread | free-keypoint grid, 2 threads | matches |\n");
  std::printf("|---|---|---|---|---|\n");
  bool same = true;
  for (const bool last_frame : {false, true}) {
    std::vector<ProjectionCandidate> candidates;
    for (size_t j = 0; j < scene.points_in_world.size(); ++j) {
      ProjectionCandidate c;
      c.landmark_id = 1000 + j;
      c.position_in_world = scene.points_in_world[j];
      c.descriptor = scene.descriptors[j];
      c.radius_px = last_frame ? 15.f : 10.f;
      c.reference_angle_deg = 0.f;
      candidates.push_back(c);
    }
    ProjectionMatchOptions base;
    base.ratio = last_frame ? 1.f : 0.8f;
    base.check_orientation = last_frame;
    std::string cells;
    std::vector<Id> reference;
    int matches = 0;
    for (const auto& [cell_px, threads] : {std::pair{0, 1}, std::pair{8, 1}, std::pair{8, 2}}) {
      ProjectionMatchOptions options = base;
      options.search_cell_px = cell_px;
      options.num_threads = threads;
      ProjectionMatchScratch scratch;
      std::vector<double> wall_ms, cpu_ms;
      Frame frame;
      for (int r = 0; r < reps; ++r) {
        frame = start;
        const double cpu0 = ThreadCpuMs();
        const auto t0 = std::chrono::steady_clock::now();
        matches = MatchByProjection(candidates, perturbed, options, &frame, &scratch);
        wall_ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count());
        cpu_ms.push_back(ThreadCpuMs() - cpu0);
      }
      if (reference.empty()) reference = frame.landmark_ids;
      same = same && frame.landmark_ids == reference;
      char cell[64];
      std::snprintf(cell, sizeof(cell), " %.3f / %.3f |", Median(wall_ms), Median(cpu_ms));
      cells += cell;
    }
    std::printf("| %s |%s %d |\n", last_frame ? "last frame (15 px, ratio 1)" : "local map (10 px, ratio 0.8)",
                cells.c_str(), matches);
  }
  std::printf("\nmatches %s across the three settings\n", same ? "the same" : "DIFFER");
  return same ? 0 : 1;
}
