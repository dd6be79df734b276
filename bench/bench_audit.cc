// Timings of the privacy audit (privacy/audit.h) on synthetic street line clouds of 100k and 1M
// lines (or the sizes given), with the density attack's recovery against the ground truth.
//
//   build/bench_audit [SIZES=100000,1000000] [THREADS=0]
//
// Prints one block per size: wall time of each stage and the whole audit, and the recovered
// fractions. Not run by ctest.
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "mapping/synthetic_map.h"
#include "privacy/audit.h"
#include "slam/geometry/line3.h"

namespace {

using Clock = std::chrono::steady_clock;
double Since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// The publishing rule of mapping/line_cloud.h, inlined so that the benchmark depends only on the
// synthetic map generator.
lcv::slam::Map ToLineCloud(const lcv::slam::Map& points, std::uint64_t seed) {
  lcv::slam::Map out;
  out.cameras = points.cameras;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (const auto& [id, p] : points.points) {
    lcv::slam::LineLandmark l;
    l.id = id;
    const double a = u(rng), b = u(rng);
    const Eigen::Vector3d d = lcv::slam::UniformUnitVector(a, b);
    l.line = lcv::slam::Line3d(p.position - d.dot(p.position) * d, d);
    l.information = lcv::slam::LineInformation(d, p.covariance);
    l.descriptor = p.descriptor;
    for (const auto& obs : p.observations) l.server_keyframe_ids.push_back(obs.keyframe_id);
    out.lines[id] = std::move(l);
  }
  for (const auto& [id, kf] : points.keyframes) {
    lcv::slam::ServerKeyframe s;
    s.id = id;
    s.camera_id = kf.camera_id;
    s.cam_from_world = kf.cam_from_world;
    out.server_keyframes[id] = s;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes;
  {
    std::stringstream list(argc > 1 ? argv[1] : "100000,1000000");
    std::string item;
    while (std::getline(list, item, ',')) sizes.push_back(std::atoi(item.c_str()));
  }
  const int threads = argc > 2 ? std::atoi(argv[2]) : 0;
  for (int n : sizes) {
    lcv::mapping::SyntheticMapOptions synth;
    synth.num_points = n;
    synth.num_keyframes = 100;
    synth.seed = 1;
    auto t = Clock::now();
    lcv::slam::Map points = lcv::mapping::MakeSyntheticPointMap(synth);
    // Keyframes' keypoints are not needed by the audit; free them.
    const double t_synth = Since(t);
    t = Clock::now();
    const lcv::slam::Map lines = ToLineCloud(points, 2);
    points.keyframes.clear();
    const double t_convert = Since(t);

    lcv::privacy::AuditInputs inputs;
    inputs.map = &lines;
    inputs.reference = &points;
    lcv::privacy::AuditOptions options;
    options.num_threads = threads;
    t = Clock::now();
    const std::clock_t cpu_start = std::clock();
    const lcv::privacy::AuditReport report = lcv::privacy::RunAudit(inputs, options);
    const double t_audit = Since(t);
    // CPU time of all threads: the wall time depends on what else runs on the machine.
    const double cpu_audit = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    std::printf("== %d lines (%zu server keyframes), threads %d\n", n,
                lines.server_keyframes.size(), threads);
    std::printf("  synthetic map %.1f s, conversion %.1f s (not part of the audit)\n", t_synth,
                t_convert);
    for (const auto& a : report.attacks) {
      std::printf("  %-10s %7.1f s", a.result.name.c_str(), a.seconds);
      if (a.recovery) {
        for (std::size_t k = 0; k < a.recovery->fractions.size(); ++k) {
          std::printf("  %s %.3f", a.recovery->tolerances[k].Label().c_str(),
                      a.recovery->fractions[k]);
        }
        std::printf("  median %.3g m", a.recovery->median_error_m);
      }
      std::printf("\n");
    }
    std::printf("  whole audit %.1f s wall, %.1f s CPU (all threads), passed %s\n", t_audit,
                cpu_audit, report.passed ? "yes" : "no");
    std::fflush(stdout);
  }
  return 0;
}
