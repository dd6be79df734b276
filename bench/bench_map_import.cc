// Map reuse load time (not run by ctest): ReadMap (file read + decode + validation) and
// ImportSlamMap (slam/data/slam_map_import.h) of a saved map, wall clock and thread CPU time,
// best and median of REPEATS runs (CPU time is the one to compare on a loaded machine).
//
//   build/bench_map_import [--repeats R] [MAP]
//
// Without MAP: synthesizes a map shaped like an lcv slam map of a long sequence (300 keyframes,
// 1500 keypoints each with descriptors, every point seen by 4 consecutive keyframes, ~45% of the
// keypoints on points) into $TMPDIR/bench_map_import.lcmap and loads that.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "mapping/io/map_file.h"
#include "slam/data/slam_map_import.h"

namespace {

using lcv::slam::Id;

double NowMs() {
  return std::chrono::duration<double, std::milli>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double CpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

void Print(const char* label, std::vector<double> wall, std::vector<double> cpu) {
  std::sort(wall.begin(), wall.end());
  std::sort(cpu.begin(), cpu.end());
  std::printf("%-14s wall best %7.1f ms median %7.1f ms   cpu best %7.1f ms median %7.1f ms\n",
              label, wall.front(), wall[wall.size() / 2], cpu.front(), cpu[cpu.size() / 2]);
}

lcv::slam::Map SynthesizeMap(int num_keyframes, int keypoints_per_keyframe) {
  using namespace lcv::slam;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<float> ux(0.f, 639.f), uy(0.f, 359.f), angle(0.f, 360.f);
  std::uniform_int_distribution<int> octave(0, 7), byte(0, 255);
  std::uniform_real_distribution<double> lateral(-3.0, 3.0), depth(4.0, 20.0);
  Map map;
  CameraParams camera;
  camera.model = CameraModel::kPerspective;
  camera.cols = 640;
  camera.rows = 360;
  camera.fx = camera.fy = 400;
  camera.cx = 319.5;
  camera.cy = 179.5;
  map.cameras[0] = camera;
  Id next_id = 1;
  std::vector<Id> keyframe_ids;
  for (int k = 0; k < num_keyframes; ++k) {
    Keyframe kf;
    kf.id = next_id++;
    kf.camera_id = 0;
    kf.timestamp = 0.1 * k;
    kf.cam_from_world = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.5 * k, 0, 0));
    for (int i = 0; i < keypoints_per_keyframe; ++i) {
      kf.keypoints.push_back({ux(rng), uy(rng), angle(rng), octave(rng)});
      OrbDescriptor d;
      for (auto& b : d) b = static_cast<std::uint8_t>(byte(rng));
      kf.descriptors.push_back(d);
    }
    keyframe_ids.push_back(kf.id);
    map.keyframes[kf.id] = std::move(kf);
  }
  // Points seen by 4 consecutive keyframes; keypoint i of keyframe k holds point (k, i / 4 ...)
  // chosen so each keyframe's keypoints are used at most once.
  const int per_keyframe = keypoints_per_keyframe * 45 / 100;  // keypoints on points
  const int new_per_keyframe = per_keyframe / 4;
  for (int k = 0; k + 3 < num_keyframes; ++k) {
    for (int j = 0; j < new_per_keyframe; ++j) {
      PointLandmark point;
      point.id = next_id++;
      point.position = Eigen::Vector3d(0.5 * k + lateral(rng), lateral(rng), depth(rng));
      for (int o = 0; o < 4; ++o) {
        // Keypoint slot: keyframe k + o uses slots [o * new, (o + 1) * new) for points born
        // o keyframes earlier.
        point.observations.push_back(
            {keyframe_ids[k + o], static_cast<std::uint32_t>(o * new_per_keyframe + j)});
      }
      const Keyframe& first = map.keyframes.at(keyframe_ids[k]);
      point.descriptor = first.descriptors[j];
      point.covariance = Eigen::Matrix3d::Identity() * 1e-4;
      map.points[point.id] = std::move(point);
    }
  }
  map.description = "bench_map_import synthetic";
  return map;
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 5;
  std::string path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--repeats" && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else {
      path = arg;
    }
  }
  if (path.empty()) {
    const char* tmp = std::getenv("TMPDIR");
    path = std::string(tmp ? tmp : "/tmp") + "/bench_map_import.lcmap";
    lcv::mapping::WriteMap(SynthesizeMap(300, 1500), path);
    std::printf("synthesized %s\n", path.c_str());
  }
  std::vector<double> read_ms, import_ms, read_cpu, import_cpu;
  std::size_t keyframes = 0, points = 0, observations = 0;
  for (int r = 0; r < repeats; ++r) {
    const double t0 = NowMs(), c0 = CpuMs();
    const lcv::slam::Map map = lcv::mapping::ReadMap(path);
    const double t1 = NowMs(), c1 = CpuMs();
    const auto camera =
        lcv::slam::MakeCamera(map.cameras.at(map.keyframes.begin()->second.camera_id));
    const lcv::slam::SlamMap slam_map =
        lcv::slam::ImportSlamMap(map, *camera, lcv::slam::ScaleLevels());
    const double t2 = NowMs(), c2 = CpuMs();
    read_ms.push_back(t1 - t0);
    import_ms.push_back(t2 - t1);
    read_cpu.push_back(c1 - c0);
    import_cpu.push_back(c2 - c1);
    keyframes = slam_map.keyframes().size();
    points = slam_map.landmarks().size();
    observations = 0;
    for (const auto& [id, landmark] : slam_map.landmarks()) {
      observations += landmark.observations.size();
    }
  }
  std::printf("%s: %zu keyframes, %zu points, %zu observations\n", path.c_str(), keyframes, points,
              observations);
  Print("ReadMap", read_ms, read_cpu);
  Print("ImportSlamMap", import_ms, import_cpu);
  return 0;
}
