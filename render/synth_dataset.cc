#include "render/synth_dataset.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <ostream>

#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/media.h"
#include "mapping/io/camera_file.h"
#include "mapping/io/trajectory.h"
#include "render/scene_renderer.h"
#include "slam/util/error.h"

namespace lcv::render {
namespace {

using Clock = std::chrono::steady_clock;

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

void MakeDirectories(const std::string& path) {
  std::error_code error;
  std::filesystem::create_directories(path, error);
  if (error) throw InputError(path, "cannot create folder: " + error.message());
}

std::string FrameName(int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.png", index);
  return name;
}

}  // namespace

nlohmann::json SceneDescription(const Scenario& scenario, const slam::CameraParams& camera,
                                int supersampling) {
  nlohmann::json doc;
  doc["format"] = "lcv-synth-scene";
  doc["version"] = 1;
  doc["scenario"] = scenario.name;
  doc["seed"] = scenario.seed;
  doc["fps"] = scenario.fps;
  doc["supersampling"] = supersampling;
  doc["world_frame"] =
      "metres, z up; groundtruth.txt holds world_from_cam (TUM: t is the camera centre)";
  doc["camera"] = {{"model", slam::CameraModelName(camera.model)}, {"cols", camera.cols},
                   {"rows", camera.rows}, {"fx", camera.fx}, {"fy", camera.fy},
                   {"cx", camera.cx}, {"cy", camera.cy}, {"distortion", camera.distortion}};
  nlohmann::json objects = nlohmann::json::array();
  nlohmann::json concealed_map = nlohmann::json::array(), concealed_client = nlohmann::json::array();
  for (const auto& o : scenario.scene.objects) {
    objects.push_back({{"id", o.id}, {"name", o.name}, {"kind", o.kind},
                       {"bbox_min", Vec(o.bbox_min)}, {"bbox_max", Vec(o.bbox_max)},
                       {"in_map", o.in_map}, {"in_client", o.in_client}});
    if (!o.in_map) concealed_map.push_back(o.id);
    if (!o.in_client) concealed_client.push_back(o.id);
  }
  doc["objects"] = objects;
  doc["concealed"] = {{"map", concealed_map}, {"client", concealed_client}};
  doc["sequences"] = {
      {"map", {{"path", "map"}, {"frames", scenario.map_cam_from_world.size()}}},
      {"client", {{"path", "client"}, {"frames", scenario.client_cam_from_world.size()}}}};
  nlohmann::json points = nlohmann::json::array();
  for (const auto& p : scenario.scene.ground_truth_points) {
    const auto& o = scenario.scene.objects.at(p.object_id);
    points.push_back({{"id", p.id}, {"object_id", p.object_id}, {"position", Vec(p.position)},
                      {"marker_square_m", p.marker_square_m},
                      {"normal", Vec(p.axis_u.cross(p.axis_v))}, {"in_map", o.in_map},
                      {"in_client", o.in_client}});
  }
  doc["ground_truth_points_note"] =
      "centres of checker markers drawn into the textures: sharp X-corners at these positions";
  doc["ground_truth_points"] = points;
  return doc;
}

SynthDatasetReport WriteSynthDataset(const SynthDatasetOptions& options, std::ostream* progress) {
  LCV_CHECK(options.frames >= 1 && options.cols > 0 && options.rows > 0 && !options.out_dir.empty());
  const Scenario scenario = MakeScenario(options.scenario, options.frames, options.seed);
  const slam::CameraParams camera =
      SynthCamera(options.camera_model, options.cols, options.rows, scenario.fps);
  const auto problem = camera.Problem();
  LCV_CHECK(!problem) << *problem;

  const std::filesystem::path root(options.out_dir);
  MakeDirectories(root.string());
  const nlohmann::json scene_json = SceneDescription(scenario, camera, options.supersampling);
  mapping::WriteFileAtomically((root / "scene.json").string(), scene_json.dump(1) + "\n");

  SceneRenderOptions render_options;
  render_options.supersampling = options.supersampling;
  SceneRenderer renderer(scenario.scene, render_options);
  SynthDatasetReport report;
  report.objects = static_cast<int>(scenario.scene.objects.size());
  report.ground_truth_points = static_cast<int>(scenario.scene.ground_truth_points.size());
  double render_seconds = 0.0, total_seconds = 0.0;
  const int total_frames = 2 * options.frames;
  for (const SequenceKind kind : {SequenceKind::kMap, SequenceKind::kClient}) {
    const bool is_map = kind == SequenceKind::kMap;
    const auto& poses = is_map ? scenario.map_cam_from_world : scenario.client_cam_from_world;
    const std::filesystem::path dir = root / (is_map ? "map" : "client");
    MakeDirectories((dir / "images").string());
    mapping::WriteCameraFile(camera, (dir / "camera.yaml").string());
    mapping::Trajectory trajectory;
    std::string times;
    for (size_t i = 0; i < poses.size(); ++i) {
      const auto t0 = Clock::now();
      const cv::Mat image = renderer.Render(camera, poses[i], kind);
      const auto t1 = Clock::now();
      const std::string image_path = (dir / "images" / FrameName(static_cast<int>(i))).string();
      const std::vector<unsigned char> png = mapping::EncodePng(image, 3, image_path);
      mapping::WriteFileAtomically(image_path, std::string(png.begin(), png.end()));
      const auto t2 = Clock::now();
      render_seconds += std::chrono::duration<double>(t1 - t0).count();
      total_seconds += std::chrono::duration<double>(t2 - t0).count();
      const double timestamp = static_cast<double>(i) / scenario.fps;
      trajectory.poses.push_back({timestamp, poses[i]});
      times += mapping::FormatDoubleExact(timestamp) + "\n";
      ++report.frames_written;
      const int step = std::max(1, total_frames / 10);
      if (progress && (report.frames_written % step == 0 || report.frames_written == total_frames)) {
        char line[160];
        std::snprintf(line, sizeof(line), "synth: %s %zu/%zu frames (%.1f ms/frame render, %.1f ms total)\n",
                      is_map ? "map" : "client", i + 1, poses.size(),
                      1e3 * render_seconds / report.frames_written,
                      1e3 * total_seconds / report.frames_written);
        *progress << line << std::flush;
      }
    }
    mapping::WriteTrajectory(trajectory, (dir / "groundtruth.txt").string(),
                             mapping::TrajectoryFormat::kTum);
    mapping::WriteFileAtomically((dir / "times.txt").string(), times);
  }
  report.mean_render_ms = 1e3 * render_seconds / std::max(1, report.frames_written);
  report.mean_frame_ms = 1e3 * total_seconds / std::max(1, report.frames_written);
  return report;
}

}  // namespace lcv::render
