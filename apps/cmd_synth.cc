// `lcv synth`: renders a synthetic sequence pair (map + client) with exact ground truth.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>

#include "apps/args.h"
#include "apps/command.h"
#include "render/offscreen_context.h"
#include "render/synth_dataset.h"
#include "render/synth_scenario.h"

namespace lcv::apps {
namespace {

int RunSynth(int argc, char** argv) {
  std::string scenario_list;
  for (const auto& name : render::ScenarioNames()) {
    scenario_list += (scenario_list.empty() ? "" : "|") + name;
  }
  ArgParser args(
      "lcv synth --scenario NAME --camera MODEL --frames N --size WxH --seed S --out DIR",
      "Renders a textured synthetic world offscreen (OSMesa, no display) into a pair of image\n"
      "sequences with exact ground truth, mirroring the paper's CARLA protocol:\n"
      "  tracking  street; client drives almost the map sequence's path\n"
      "  overlap   street; the two sequences overlap over part of it\n"
      "  loop      city block; the client leaves the mapped part and returns (loop closure)\n"
      "  desk      room with a desk; a privacy object is in the map sequence only\n"
      "Writes DIR/scene.json and DIR/map/, DIR/client/ (images/*.png, camera.yaml,\n"
      "groundtruth.txt (TUM, camera-to-world), times.txt). Fisheye and equirectangular frames\n"
      "are resampled from a cube map through the project's camera models.\n"
      "Same arguments give identical files.",
      "lcv synth --scenario loop --camera fisheye --frames 200 --seed 1 --out out/loop_fisheye");
  args.AddOption("--scenario", "NAME", scenario_list, "tracking");
  args.AddOption("--camera", "MODEL", "perspective|fisheye|equirectangular", "perspective");
  args.AddOption("--frames", "N", "frames per sequence", "100");
  args.AddOption("--size", "WxH", "image size (equirectangular default 640x320)", "640x360");
  args.AddOption("--seed", "S", "seed of the scene's layout and textures", "0");
  args.AddOption("--supersampling", "K",
                 "K x K samples per pixel, averaged like a sensor pixel; 1: point sampling "
                 "(the renderer before 2026-11-27)",
                 "3");
  args.AddOption("--out", "DIR", "output folder (created)");
  if (!args.Parse(argc, argv)) return kExitOk;

  render::SynthDatasetOptions options;
  options.scenario = args.Get("--scenario");
  bool known = false;
  for (const auto& name : render::ScenarioNames()) known |= name == options.scenario;
  if (!known) {
    throw UsageError("--scenario: unknown scenario '" + options.scenario + "' (" + scenario_list + ")");
  }
  const std::string model_name = args.Get("--camera");
  const auto model = slam::ParseCameraModel(model_name);
  if (!model) {
    throw UsageError("--camera: unknown model '" + model_name +
                     "' (perspective|fisheye|equirectangular)");
  }
  options.camera_model = *model;
  options.frames = args.GetInt("--frames");
  if (options.frames < 1 || options.frames > 100000) {
    throw UsageError("--frames: " + std::to_string(options.frames) + " is not in [1, 100000]");
  }
  if (!args.Has("--size") && *model == slam::CameraModel::kEquirectangular) {
    options.cols = 640;
    options.rows = 320;
  } else {
    std::tie(options.cols, options.rows) = args.GetSize("--size");
  }
  options.seed = args.GetSeed();
  options.supersampling = args.GetInt("--supersampling");
  if (options.supersampling < 1 || options.supersampling > 8) {
    throw UsageError("--supersampling: " + std::to_string(options.supersampling) +
                     " is not in [1, 8]");
  }
  // The fine image is rendered whole, in one offscreen buffer.
  if (std::max(options.cols, options.rows) * options.supersampling > render::kMaxOffscreenSide) {
    throw UsageError("--supersampling: " + std::to_string(options.supersampling) + " times " +
                     std::to_string(options.cols) + "x" + std::to_string(options.rows) +
                     " exceeds the renderer's " + std::to_string(render::kMaxOffscreenSide) +
                     " px per side");
  }
  options.out_dir = args.Get("--out");

  std::cerr << "synth: scenario " << options.scenario << ", " << model_name << " " << options.cols
            << "x" << options.rows << ", " << options.frames << " frames per sequence, seed "
            << options.seed << " -> " << options.out_dir << "\n";
  const auto report = render::WriteSynthDataset(options, &std::cerr);
  std::printf("wrote %s: %d frames (map + client), %d objects, %d ground-truth points\n",
              options.out_dir.c_str(), report.frames_written, report.objects,
              report.ground_truth_points);
  std::printf("render %.1f ms/frame, with PNG encoding and writing %.1f ms/frame\n",
              report.mean_render_ms, report.mean_frame_ms);
  return kExitOk;
}

}  // namespace
LCV_REGISTER_COMMAND("synth", "render a synthetic sequence pair with ground truth", RunSynth);
}  // namespace lcv::apps
