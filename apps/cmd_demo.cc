// `lcv demo`: the main job on built-in data, end to end, as far as the project goes today:
//   1. render a synthetic street sequence pair with ground truth (`lcv synth`, scenario
//      "tracking", perspective 640x360);
//   2. run monocular visual SLAM over the map sequence (deterministic mode) and score its
//      trajectory against the ground truth (APE after Sim(3) alignment, as evo);
//   3. publish the SLAM point map as a line cloud (random directions, re-drawn anchors, every
//      keypoint and observation dropped), write it and read it back;
//   4. audit the published line cloud against the hidden points (format leaks, direction
//      randomness, duplicate lines, density / visibility attacks);
//   5. render snapshots of the point map and of the line cloud.
// Results go to --out (default ./lcv-demo); a short summary goes to stdout. Exit 3 when the
// audit fails.

#include <sys/stat.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include <opencv2/core/mat.hpp>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/eval/trajectory_error.h"
#include "mapping/io/dataset.h"
#include "mapping/io/map_file.h"
#include "mapping/io/trajectory.h"
#include "mapping/line_cloud.h"
#include "privacy/audit.h"
#include "render/map_snapshot.h"
#include "render/synth_dataset.h"
#include "slam/system.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

void MakeDirectory(const std::string& path) {
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST) {
    throw InputError(path, "cannot create folder");
  }
}

void WriteSnapshot(const slam::Map& map, render::SnapshotView view, const std::string& path) {
  render::SnapshotOptions options;
  options.view = view;
  options.legend = true;
  render::WritePng(render::RenderMapSnapshot(map, options).image, path);
}

int RunDemo(int argc, char** argv) {
  ArgParser args("lcv demo [--out DIR] [--frames N] [--seed N]",
                 "Runs the main job on built-in synthetic data: renders a street sequence with "
                 "ground truth,\nruns visual SLAM on it, publishes the map as a line cloud, "
                 "audits the line cloud and\nrenders snapshots. Everything is written to --out.",
                 "lcv demo --out /tmp/lcv-demo");
  args.AddOption("--out", "DIR", "folder for the results", "lcv-demo");
  args.AddOption("--frames", "N", "frames of the synthetic sequence", "80");
  args.AddOption("--seed", "N", "seed of the scene, the SLAM and the line directions", "1");
  if (!args.Parse(argc, argv)) return kExitOk;
  const std::string out = args.Get("--out");
  const std::uint64_t seed = args.GetSeed();
  const int frames = args.GetInt("--frames");
  if (frames < 20) throw UsageError("--frames: at least 20 frames are needed to initialize");
  MakeDirectory(out);
  const auto start = std::chrono::steady_clock::now();

  std::cerr << "[demo 1/5] rendering the synthetic street sequence\n";
  render::SynthDatasetOptions synth;
  synth.scenario = "tracking";
  synth.frames = frames;
  synth.seed = seed;
  synth.out_dir = out + "/scene";
  render::WriteSynthDataset(synth, &std::cerr);

  std::cerr << "[demo 2/5] visual SLAM on the map sequence\n";
  mapping::DatasetOptions dataset_options;
  dataset_options.sequence = "map";
  const auto dataset = mapping::OpenDataset(synth.out_dir, dataset_options);
  slam::SystemOptions slam_options;
  slam_options.deterministic = true;
  slam_options.seed = seed;
  slam_options.initializer.seed = seed;
  slam_options.features.num_features =
      slam::DefaultNumFeatures(dataset->camera().cols, dataset->camera().rows);
  slam::System system(dataset->camera(), slam_options);
  int tracked = 0;
  for (size_t i = 0; i < dataset->size(); ++i) {
    const slam::FrameResult r = system.TrackImage(dataset->LoadImage(i, true),
                                                  dataset->frames()[i].timestamp);
    tracked += r.state == slam::TrackingState::kTracking;
  }
  system.Finish();
  const mapping::Trajectory trajectory = mapping::MakeTrajectory(system.FrameTrajectory());
  mapping::WriteTrajectory(trajectory, out + "/trajectory.txt", mapping::TrajectoryFormat::kTum);
  slam::Map point_map = system.ExportMap();
  point_map.description = "lcv demo: lcv slam on " + synth.out_dir + "/map";
  mapping::WriteMap(point_map, out + "/slam_map.lcmap");
  mapping::TrajectoryErrorOptions ape_options;
  ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
  const auto ape = mapping::ComputeApe(dataset->GroundTruth(), trajectory, ape_options);

  std::cerr << "[demo 3/5] publishing the map as a line cloud\n";
  mapping::LineCloudOptions publish;
  publish.seed = seed;
  mapping::WriteMap(mapping::ConvertToLineCloud(point_map, publish), out + "/line_cloud.lcmap");
  const slam::Map line_cloud = mapping::ReadMap(out + "/line_cloud.lcmap");

  std::cerr << "[demo 4/5] auditing the line cloud\n";
  privacy::AuditInputs audit_inputs;
  audit_inputs.map = &line_cloud;
  audit_inputs.reference = &point_map;
  privacy::AuditReport audit = privacy::RunAudit(audit_inputs, {}, &std::cerr);
  privacy::WriteAuditReport(&audit, out + "/audit.json");

  std::cerr << "[demo 5/5] rendering snapshots\n";
  WriteSnapshot(point_map, render::SnapshotView::kTop, out + "/slam_map.png");
  WriteSnapshot(line_cloud, render::SnapshotView::kOblique, out + "/line_cloud.png");

  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("scene:       %s (%zu frames, ground truth)\n", synth.out_dir.c_str(),
              dataset->size());
  std::printf("slam:        %d/%zu frames tracked, %d keyframes, %zu points\n", tracked,
              dataset->size(), system.NumKeyframes(), point_map.points.size());
  if (ape.problem) {
    std::printf("APE:         not computed: %s\n", ape.problem->c_str());
  } else {
    std::printf("APE (Sim3):  translation RMSE %.3f m over %d poses\n", ape.translation.rmse,
                ape.matched);
  }
  std::printf("line cloud:  %zu lines, %zu server keyframes, published: %s\n",
              line_cloud.lines.size(), line_cloud.server_keyframes.size(),
              slam::IsPublishedLineCloud(line_cloud) ? "yes" : "NO");
  std::printf("audit:       %s -> %s/audit.json\n", audit.passed ? "passed" : "FAILED", out.c_str());
  std::string recovered;
  for (const privacy::AttackOutcome& attack : audit.attacks) {
    if (!attack.recovery) continue;
    const auto& r = *attack.recovery;
    for (size_t k = 0; k < r.tolerances.size(); ++k) {
      if (r.tolerances[k].relative && r.tolerances[k].value == 0.05) {
        char buffer[64];
        std::snprintf(buffer, sizeof buffer, "%s%s %.1f%%", recovered.empty() ? "" : ", ",
                      attack.result.name.c_str(), 100.0 * r.fractions[k]);
        recovered += buffer;
      }
    }
  }
  if (!recovered.empty()) {
    std::printf("attacks:     hidden points recovered within 5%% of the scene size: %s\n",
                recovered.c_str());
  }
  std::printf("snapshots:   %s/slam_map.png %s/line_cloud.png\n", out.c_str(), out.c_str());
  std::printf("time:        %.1f s\n", seconds);
  return audit.passed ? kExitOk : kExitCheckFailed;
}

}  // namespace
LCV_REGISTER_COMMAND("demo", "run the main job on built-in synthetic data", RunDemo);
}  // namespace lcv::apps
