// Batch map merging (issue 13): time and peak memory against the total number of uploaded lines.
// Run by hand:
//   ./build/bench_map_merge [--uploads 50] [--lines 20000] [--mode register|grow] [--optimize]
// register: every upload is an independent session of the base street (its own ids, line
//           directions, 1 cm point noise, a random Sim(3) frame): registered, mostly merged.
// grow:     every upload is a same-frame upload of new lines (its own street with its own random
//           descriptors, placed beside the base, 1/16 of its lines referring to base lines): the
//           merged map grows to ~all lines.
// Prints per-upload progress on stderr and one summary line: uploads, total lines, merged map
// size, seconds (generation excluded), peak resident memory (VmHWM).
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>

#include "mapping/line_cloud.h"
#include "mapping/map_merge.h"
#include "mapping/synthetic_map.h"
#include "privacy/map_alignment.h"
#include "slam/geometry/so3.h"

namespace {

using lcv::slam::Id;
using lcv::slam::Map;

long PeakResidentKb() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

Map Renumbered(const Map& map, Id offset) {
  Map out;
  for (const auto& [id, camera] : map.cameras) out.cameras[id + offset] = camera;
  for (const auto& [id, kf] : map.keyframes) {
    auto k = kf;
    k.id += offset;
    k.camera_id += offset;
    out.keyframes[k.id] = k;
  }
  for (const auto& [id, point] : map.points) {
    auto p = point;
    p.id += offset;
    for (auto& o : p.observations) o.keyframe_id += offset;
    out.points[p.id] = p;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  int uploads = 50, lines = 20000;
  std::string mode = "register";
  bool optimize = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--uploads" && i + 1 < argc) uploads = std::atoi(argv[++i]);
    else if (a == "--lines" && i + 1 < argc) lines = std::atoi(argv[++i]);
    else if (a == "--mode" && i + 1 < argc) mode = argv[++i];
    else if (a == "--optimize") optimize = true;
    else {
      std::fprintf(stderr, "usage: bench_map_merge [--uploads N] [--lines N] "
                           "[--mode register|grow] [--optimize]\n");
      return 2;
    }
  }
  if (mode != "register" && mode != "grow") return 2;
  lcv::mapping::SyntheticMapOptions scene;
  scene.num_points = lines;
  scene.num_keyframes = 60;
  scene.max_depth_m = 25.0;
  scene.seed = 1;
  const Map street = lcv::mapping::MakeSyntheticPointMap(scene);
  const Map base = lcv::mapping::ConvertToLineCloud(street, {1});

  lcv::mapping::MapMergeOptions options;
  options.optimize = optimize;
  if (mode == "grow") options.frame = lcv::mapping::UploadFrame::kSame;
  lcv::mapping::MapMerger merger(base, options);
  double merge_seconds = 0.0;
  std::size_t total_lines = base.lines.size();
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (int u = 0; u < uploads; ++u) {
    // Generation (not timed).
    Map upload;
    if (mode == "register") {
      Map session = Renumbered(street, 10000000ULL * (u + 1));
      for (auto& [id, p] : session.points) p.position += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      const lcv::slam::Sim3d S(0.5 + 0.05 * (u % 20),
                               lcv::slam::ExpSO3(Eigen::Vector3d(0.1 * u, -0.05 * u, 0.2)),
                               Eigen::Vector3d(u, -u, 2.0 * u));
      upload = lcv::mapping::ConvertToLineCloud(lcv::privacy::TransformMap(session, S),
                                                {static_cast<std::uint64_t>(100 + u)});
    } else {
      // A street beside the base (shifted in x), its own lines; its keyframes also see a few
      // base lines by id (a client that relocalized in the base).
      Map session = Renumbered(street, 10000000ULL * (u + 1));
      for (auto& [id, p] : session.points) p.position.x() += 30.0 * (u + 1);
      for (auto& [id, kf] : session.keyframes) {
        kf.cam_from_world = lcv::slam::TransformPose(
            lcv::slam::Sim3d(1.0, Eigen::Quaterniond::Identity(),
                             Eigen::Vector3d(30.0 * (u + 1), 0, 0)),
            kf.cam_from_world);
      }
      upload = lcv::mapping::ConvertToLineCloud(session, {static_cast<std::uint64_t>(100 + u)});
      // Another place has other features: fresh random descriptors (50 copies of one street's
      // descriptors would fill the LSH buckets with exact duplicates, which no real data does).
      for (auto& [id, line] : upload.lines) {
        lcv::slam::OrbDescriptor d;
        for (auto& byte : d) byte = static_cast<std::uint8_t>(rng());
        line.descriptor = d;
      }
      int shared = 0;
      for (const auto& [id, line] : base.lines) {
        if (shared++ == lines / 16) break;
        upload.lines[id] = line;
        upload.lines[id].server_keyframe_ids.clear();
      }
    }
    total_lines += upload.lines.size();
    const auto start = std::chrono::steady_clock::now();
    const auto result = merger.AddUpload(upload, "upload " + std::to_string(u));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    merge_seconds += seconds;
    std::fprintf(stderr, "[%d/%d] %s %s: +%d merged %d, %.2f s, map %zu lines, peak %ld MB\n",
                 u + 1, uploads, result.accepted ? "accepted" : "rejected",
                 result.frame.c_str(), result.lines_added, result.lines_merged, seconds,
                 merger.map().lines.size(), PeakResidentKb() / 1024);
  }
  const auto start = std::chrono::steady_clock::now();
  lcv::mapping::MapMergeReport report;
  const Map merged = merger.Finish(&report);
  const double finish_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("mode %s: %d uploads, %zu lines in total -> %zu lines merged map, %d dropped by "
              "the privacy rule; merge %.1f s + finish %.1f s = %.1f s; peak RSS %ld MB "
              "(generation included)\n",
              mode.c_str(), uploads, total_lines, merged.lines.size(), report.lines_dropped,
              merge_seconds, finish_seconds, merge_seconds + finish_seconds,
              PeakResidentKb() / 1024);
  return 0;
}
