// Benchmarks of render/: map snapshots of a 100,000-line line cloud at 1280x720 and synthetic
// frames of the three camera models at the paper's 640x360 (equirectangular 640x320).
// Prints median and p90 wall-clock times (and process CPU time, since other jobs may share the
// machine). Not run by ctest.
//
//   build/bench_render [--lines N] [--repeats R]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "render/map_snapshot.h"
#include "render/procedural_texture.h"
#include "render/scene_renderer.h"
#include "render/synth_scenario.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Timing {
  std::vector<double> wall_ms, cpu_ms;
  void Print(const char* what) {
    std::sort(wall_ms.begin(), wall_ms.end());
    std::sort(cpu_ms.begin(), cpu_ms.end());
    const auto at = [](const std::vector<double>& v, double q) {
      return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
    };
    std::printf("%-44s median %7.1f ms  p90 %7.1f ms  (cpu median %7.1f ms)\n", what,
                at(wall_ms, 0.5), at(wall_ms, 0.9), at(cpu_ms, 0.5));
  }
};

template <typename F>
Timing Measure(int repeats, F&& f) {
  Timing t;
  for (int i = 0; i < repeats; ++i) {
    const auto w0 = Clock::now();
    const std::clock_t c0 = std::clock();
    f(i);
    t.cpu_ms.push_back(1e3 * (std::clock() - c0) / CLOCKS_PER_SEC);
    t.wall_ms.push_back(1e3 * std::chrono::duration<double>(Clock::now() - w0).count());
  }
  return t;
}

// A street-sized line cloud: hidden points on two facades and the ground, random directions,
// anchors at the closest point to the origin, server keyframes along the street.
lcv::slam::Map MakeLineCloud(int num_lines) {
  lcv::render::SplitMix64 rng(42);
  lcv::slam::Map map;
  lcv::slam::CameraParams camera;
  camera.cols = 640;
  camera.rows = 360;
  camera.fx = camera.fy = 400;
  camera.cx = 319.5;
  camera.cy = 179.5;
  map.cameras[1] = camera;
  lcv::slam::Id id = 2;
  for (int i = 0; i < 200; ++i) {
    lcv::slam::ServerKeyframe kf;
    kf.id = id++;
    kf.camera_id = 1;
    kf.timestamp = i;
    kf.cam_from_world.translation = -Eigen::Vector3d(0, 0, 0.5 * i);  // along +z, y down
    map.server_keyframes[kf.id] = kf;
  }
  for (int i = 0; i < num_lines; ++i) {
    Eigen::Vector3d x(rng.Uniform(-8, 8), rng.Uniform(-8, 1.6), rng.Uniform(0, 100));
    const int surface = rng.UniformInt(0, 2);
    if (surface == 0) x.x() = -8;
    if (surface == 1) x.x() = 8;
    if (surface == 2) x.y() = 1.6;
    lcv::slam::LineLandmark l;
    l.id = id++;
    const Eigen::Vector3d d = lcv::slam::UniformUnitVector(rng.Uniform(), rng.Uniform());
    l.line = lcv::slam::Line3d(x - d.dot(x) * d, d);
    map.lines[l.id] = l;
  }
  return map;
}

}  // namespace

int main(int argc, char** argv) {
  int num_lines = 100000, repeats = 10;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--lines") num_lines = std::atoi(argv[i + 1]);
    if (flag == "--repeats") repeats = std::atoi(argv[i + 1]);
  }
  const lcv::slam::Map cloud = MakeLineCloud(num_lines);
  lcv::render::MapSnapshotRenderer snapshots;
  for (const auto view : {lcv::render::SnapshotView::kTop, lcv::render::SnapshotView::kOblique}) {
    lcv::render::SnapshotOptions options;
    options.view = view;
    options.legend = true;
    const std::string what = "snapshot " + std::to_string(num_lines) + " lines 1280x720 " +
                             (view == lcv::render::SnapshotView::kTop ? "top" : "oblique");
    Measure(repeats, [&](int) { snapshots.Render(cloud, options); }).Print(what.c_str());
  }
  const lcv::render::Scenario scenario = lcv::render::MakeScenario("tracking", repeats, 0);
  lcv::render::SceneRenderer renderer(scenario.scene);
  const struct {
    lcv::slam::CameraModel model;
    int cols, rows;
    const char* what;
  } cases[] = {{lcv::slam::CameraModel::kPerspective, 640, 360, "synth frame perspective 640x360"},
               {lcv::slam::CameraModel::kFisheye, 640, 360, "synth frame fisheye 640x360"},
               {lcv::slam::CameraModel::kEquirectangular, 640, 320, "synth frame equirectangular 640x320"}};
  for (const auto& c : cases) {
    const auto camera = lcv::render::SynthCamera(c.model, c.cols, c.rows);
    renderer.Render(camera, scenario.map_cam_from_world[0], lcv::render::SequenceKind::kMap);  // tables
    Measure(repeats, [&](int i) {
      renderer.Render(camera, scenario.map_cam_from_world[i], lcv::render::SequenceKind::kMap);
    }).Print(c.what);
  }
  return 0;
}
