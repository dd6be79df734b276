// `lcv render MAP --out FILE.png`: offscreen snapshots of maps (no display needed).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/media.h"
#include "mapping/io/camera_file.h"
#include "mapping/io/map_file.h"
#include "privacy/mitigation.h"
#include "render/map_snapshot.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

std::vector<std::pair<slam::Id, slam::Id>> ReadLoopEdges(const std::string& path) {
  std::istringstream in(mapping::ReadTextFile(path));
  std::string row;
  int line_number = 0;
  std::vector<std::pair<slam::Id, slam::Id>> edges;
  while (std::getline(in, row)) {
    ++line_number;
    if (row.empty() || row[0] == '#') continue;
    std::istringstream fields(row);
    unsigned long long a, b;
    if (!(fields >> a >> b)) {
      throw InputError(path, "line " + std::to_string(line_number) + ": expected two keyframe ids");
    }
    edges.emplace_back(a, b);
  }
  return edges;
}

int RunRender(int argc, char** argv) {
  ArgParser args(
      "lcv render MAP --out FILE.png [--size WxH] [--view top|oblique|keyframe:ID|orbit]\n"
      "       [--camera-file CAM --pose 'tx ty tz qx qy qz qw'] [--color-by source|risk --risk REPORT]\n"
      "       [--legend]",
      "Draws a map (.json or .lcmap) offscreen (OSMesa, no display) as the paper's figures do:\n"
      "line cloud blue (clipped to the map's bounding box), points X black, restored points X'\n"
      "orange, client keyframes green, server keyframes red, trajectories as polylines, loop\n"
      "edges magenta. --view orbit writes a turntable: an .mp4/.avi video, or numbered PNGs\n"
      "FILE_000.png ... for any other name. Same input, same pixels.",
      "lcv render out/map.lcmap --out out/map.png --view top --legend");
  args.AddPositional("MAP", "map file (.json or .lcmap)");
  args.AddOption("--out", "FILE", "output PNG (orbit: .mp4/.avi video, or numbered PNGs)");
  args.AddOption("--size", "WxH", "image size", "1280x720");
  args.AddOption("--view", "VIEW", "top | oblique | keyframe:ID | orbit", "oblique");
  args.AddOption("--azimuth", "DEG", "oblique view: azimuth around the up axis", "225");
  args.AddOption("--elevation", "DEG", "oblique/orbit views: elevation above the horizon", "35");
  args.AddOption("--frames", "N", "orbit: number of frames", "36");
  args.AddOption("--camera-file", "CAM", "explicit viewpoint: camera file (YAML/JSON)");
  args.AddOption("--pose", "POSE", "explicit viewpoint: 'tx ty tz qx qy qz qw' camera-to-world (TUM)");
  args.AddOption("--color-by", "WHAT", "source | risk", "source");
  args.AddOption("--risk", "FILE", "audit report JSON (attacks[].risk_file) or a line_id,risk CSV");
  args.AddOption("--attack", "NAME", "which attack of the report (default: largest risk of all)");
  args.AddOption("--loop-edges", "FILE",
                 "text file, one 'keyframe_id keyframe_id' pair per line (default: the map's own "
                 "loop edges)");
  args.AddSwitch("--legend", "draw a legend (and the risk colour bar)");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"--out"});  // before any work

  const std::string map_path = args.Positional("MAP");
  const std::string out = args.Get("--out");
  render::SnapshotOptions options;
  std::tie(options.cols, options.rows) = args.GetSize("--size");
  options.legend = args.Has("--legend");
  options.azimuth_deg = args.GetDouble("--azimuth");
  options.elevation_deg = args.GetDouble("--elevation");
  if (options.elevation_deg < -89 || options.elevation_deg > 89) {
    throw UsageError("--elevation: must be in [-89, 89] degrees");
  }
  const std::string view = args.Get("--view");
  bool orbit = false;
  std::optional<slam::Id> keyframe;
  if (view == "top") {
    options.view = render::SnapshotView::kTop;
  } else if (view == "oblique") {
    options.view = render::SnapshotView::kOblique;
  } else if (view == "orbit") {
    options.view = render::SnapshotView::kOblique;
    orbit = true;
  } else if (view.rfind("keyframe:", 0) == 0) {
    char* end = nullptr;
    const std::string id = view.substr(9);
    keyframe = std::strtoull(id.c_str(), &end, 10);
    if (id.empty() || *end != '\0') throw UsageError("--view: '" + view + "' needs keyframe:<id>");
    options.view = render::SnapshotView::kKeyframe;
    options.keyframe_id = *keyframe;
  } else {
    throw UsageError("--view: unknown view '" + view + "' (top|oblique|keyframe:ID|orbit)");
  }
  if (args.Has("--camera-file") != args.Has("--pose")) {
    throw UsageError("--camera-file and --pose go together");
  }
  if (args.Has("--camera-file")) {
    if (args.Has("--view")) throw UsageError("--camera-file replaces --view");
    options.view = render::SnapshotView::kExplicit;
    options.camera = mapping::ReadCameraFile(args.Get("--camera-file"));
    std::istringstream pose(args.Get("--pose"));
    double v[7];
    for (double& x : v) pose >> x;
    if (!pose || !(pose >> std::ws).eof()) {
      throw UsageError("--pose: expected 7 numbers 'tx ty tz qx qy qz qw'");
    }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (!(q.norm() > 1e-6)) throw UsageError("--pose: quaternion of zero norm");
    options.cam_from_world = slam::Rigid3d(q.normalized(), Eigen::Vector3d(v[0], v[1], v[2])).Inverse();
  }
  const std::string color_by = args.Get("--color-by");
  if (color_by == "risk") {
    if (!args.Has("--risk")) throw UsageError("--color-by risk needs --risk REPORT");
    options.color_by = render::SnapshotColorBy::kRisk;
  } else if (color_by != "source") {
    throw UsageError("--color-by: unknown '" + color_by + "' (source|risk)");
  }
  const int frames = args.GetInt("--frames");
  if (frames < 1 || frames > 3600) throw UsageError("--frames: must be in [1, 3600]");

  const auto t0 = std::chrono::steady_clock::now();
  const slam::Map map = mapping::ReadMap(map_path);
  if (keyframe && !map.keyframes.count(*keyframe) && !map.server_keyframes.count(*keyframe)) {
    throw InputError(map_path, "no keyframe or server keyframe with id " + std::to_string(*keyframe));
  }
  if (options.color_by == render::SnapshotColorBy::kRisk) {
    options.line_risk = privacy::ReadRisks(args.Get("--risk"), args.GetOptional("--attack"));
    size_t known = 0;
    for (const auto& [id, r] : options.line_risk) known += map.lines.count(id);
    std::cerr << "render: risk for " << known << " of " << map.lines.size() << " lines\n";
  }
  options.loop_edges = args.Has("--loop-edges") ? ReadLoopEdges(args.Get("--loop-edges"))
                                                : map.loop_edges;
  const auto t1 = std::chrono::steady_clock::now();

  render::MapSnapshotRenderer renderer;
  if (!orbit) {
    const render::Snapshot snapshot = renderer.Render(map, options);
    const auto t2 = std::chrono::steady_clock::now();
    render::WritePng(snapshot.image, out);
    std::printf("wrote %s (%dx%d): %zu lines, %zu points, %zu keyframes, %zu server keyframes\n",
                out.c_str(), options.cols, options.rows, map.lines.size(), map.points.size(),
                map.keyframes.size(), map.server_keyframes.size());
    std::printf("read %.0f ms, render %.0f ms\n",
                1e3 * std::chrono::duration<double>(t1 - t0).count(),
                1e3 * std::chrono::duration<double>(t2 - t1).count());
    return kExitOk;
  }
  const std::string extension = std::filesystem::path(out).extension().string();
  const bool video = extension == ".mp4" || extension == ".avi";
  std::unique_ptr<mapping::VideoWriter> writer;
  if (video) {
    writer = mapping::CreateVideoFile(out, extension == ".mp4" ? "mp4v" : "MJPG", 12.0,
                                      cv::Size(options.cols, options.rows));
    if (!writer) {
      throw InputError(out, "cannot open a video writer (codec unavailable or folder missing)");
    }
  }
  const std::string stem = (std::filesystem::path(out).parent_path() /
                            std::filesystem::path(out).stem()).string();
  for (int i = 0; i < frames; ++i) {
    options.azimuth_deg = args.GetDouble("--azimuth") + 360.0 * i / frames;
    const render::Snapshot snapshot = renderer.Render(map, options);
    if (video) {
      writer->Write(snapshot.image);
    } else {
      char name[32];
      std::snprintf(name, sizeof(name), "_%03d.png", i);
      render::WritePng(snapshot.image, stem + name);
    }
    if ((i + 1) % std::max(1, frames / 4) == 0) std::cerr << "render: orbit " << i + 1 << "/" << frames << "\n";
  }
  std::printf("wrote %s: %d orbit frames (%dx%d)\n", video ? out.c_str() : (stem + "_000.png ...").c_str(),
              frames, options.cols, options.rows);
  return kExitOk;
}

}  // namespace
LCV_REGISTER_COMMAND("render", "draw a map to PNG offscreen (snapshots, orbits, risk colours)", RunRender);
}  // namespace lcv::apps
