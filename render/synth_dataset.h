#pragma once
// Writes a synthetic sequence pair in the project's dataset layout (read as format "lcv"):
//
//   DIR/scene.json                    scenario, seed, camera, objects with bounding boxes, which
//                                     objects are concealed in which sequence, ground-truth points
//   DIR/map/, DIR/client/             one sequence each:
//     images/000000.png ...           8-bit BGR PNG, one per frame
//     camera.yaml                     the camera (mapping/io/camera_file.h)
//     groundtruth.txt                 TUM, world_from_cam, metres, one line per image, same order
//     times.txt                       one timestamp (s) per line
//
// Every file is written atomically. Same options -> identical files (images included).

#include <cstdint>
#include <iosfwd>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "render/synth_scenario.h"
#include "slam/camera/camera.h"

namespace lcv::render {

struct SynthDatasetOptions {
  std::string scenario = "tracking";  // one of ScenarioNames()
  slam::CameraModel camera_model = slam::CameraModel::kPerspective;
  int frames = 100;  // per sequence, >= 1
  int cols = 640;    // px
  int rows = 360;    // px
  std::uint64_t seed = 0;
  // k x k samples per pixel, averaged (render/scene_renderer.h). 1 is the older point-sampled
  // rendering, whose texture filtering biases corner positions enough to shrink a monocular
  // SLAM map (docs/datasets.md, "Supersampling").
  int supersampling = 3;
  std::string out_dir;  // created if missing
};

struct SynthDatasetReport {
  int frames_written = 0;           // over both sequences
  double mean_render_ms = 0.0;      // per frame, rendering only
  double mean_frame_ms = 0.0;       // per frame, rendering + PNG encoding + writing
  int ground_truth_points = 0;
  int objects = 0;
};

// Renders and writes both sequences. progress (may be null) gets a line every ~10 % of frames.
// Precondition: options checked by the caller (scenario known, frames >= 1, size > 0,
// supersampling >= 1; std::logic_error otherwise). Throws lcv::InputError when the output
// cannot be written.
SynthDatasetReport WriteSynthDataset(const SynthDatasetOptions& options, std::ostream* progress);

// The scene.json document of a scenario rendered with camera, k x k samples per pixel.
nlohmann::json SceneDescription(const Scenario& scenario, const slam::CameraParams& camera,
                                int supersampling);

}  // namespace lcv::render
