// `lcv demo`: the main job on built-in data, end to end, as far as the project goes today:
//   1. render a synthetic street sequence pair with ground truth (`lcv synth`, scenario
//      "tracking", perspective 640x360);
//   2. run monocular visual SLAM over the map sequence (deterministic mode) and score its
//      trajectory against the ground truth (APE after Sim(3) alignment, as evo);
//   3. publish the SLAM point map behind the privacy gate (`lcv map publish` with the audit's
//      default risk limits: convert with random directions, re-drawn anchors, every keypoint
//      and observation dropped; audit; drop the lines the attacks recover until the limits hold),
//      write it and read it back;
//   4. the gate's last audit of the published line cloud against the hidden points (format
//      leaks, direction randomness, duplicate lines, density / visibility attacks, limits);
//   5. render snapshots of the point map and of the line cloud;
//   6. the paper's Desk experiment: render the `desk` scene (a privacy object in the map sequence
//      only), run SLAM on its map sequence, align it to the scene's ground truth and publish it
//      as the server's line cloud; run the LC-VSLAM client on the client sequence inside that
//      line cloud (it initializes on its own, relocalizes in the line cloud, tracks and maps in
//      the server's frame, restoring X' on the lines it observes), score it in the server's
//      frame with no alignment of its own, and audit the line cloud with the client's real
//      points X and X' and the scene's concealed object (check 3: no client point near a
//      concealed line);
//   7. the server's side: the client's upload merged into the server's line cloud (same frame,
//      one line per physical point, global optimization with virtual observations) and audited.
// Results go to --out (default ./lcv-demo); a short summary goes to stdout. Exit 3 when an
// audit fails.

#include <sys/stat.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>

#include <opencv2/core/mat.hpp>

#include "apps/args.h"
#include "apps/command.h"
#include "apps/publish_gate.h"
#include "apps/slam_config.h"
#include "mapping/eval/trajectory_error.h"
#include "mapping/io/dataset.h"
#include "mapping/io/map_file.h"
#include "mapping/io/trajectory.h"
#include "mapping/line_cloud.h"
#include "mapping/map_merge.h"
#include "privacy/audit.h"
#include "privacy/concealed_regions.h"
#include "privacy/map_alignment.h"
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

// SLAM (deterministic) over one sequence of a synthetic scene.
struct SlamRun {
  slam::Map map;
  mapping::Trajectory trajectory;
  mapping::Trajectory ground_truth;
  int frames = 0;
  int tracked = 0;
  int keyframes = 0;
  slam::SystemStats stats;
};

// line_cloud: when given, the LC-VSLAM client runs in it (`lcv slam --map-in LINES`).
SlamRun RunSlam(const std::string& scene_dir, const std::string& sequence, std::uint64_t seed,
                const slam::Map* line_cloud = nullptr) {
  mapping::DatasetOptions dataset_options;
  dataset_options.sequence = sequence;
  const auto dataset = mapping::OpenDataset(scene_dir, dataset_options);
  slam::SystemOptions slam_options = OptionsWithoutCameraDefaults();  // as `lcv slam`
  slam_options.deterministic = true;
  slam_options.seed = seed;
  slam_options.initializer.seed = seed;
  ApplyCameraDefaults(dataset->camera(), &slam_options);
  slam::System system(dataset->camera(), slam_options);
  if (line_cloud != nullptr) system.LoadMap(*line_cloud);
  SlamRun run;
  run.frames = static_cast<int>(dataset->size());
  for (size_t i = 0; i < dataset->size(); ++i) {
    const slam::FrameResult r = system.TrackImage(dataset->LoadImage(i, true),
                                                  dataset->frames()[i].timestamp);
    run.tracked += r.state == slam::TrackingState::kTracking;
  }
  system.Finish();
  run.trajectory = mapping::MakeTrajectory(system.FrameTrajectory());
  run.ground_truth = dataset->GroundTruth();
  run.keyframes = system.NumKeyframes();
  run.map = system.ExportMap();
  run.map.description = "lcv demo: lcv slam on " + scene_dir + "/" + sequence;
  run.stats = system.Stats();
  return run;
}

// The SLAM map in the scene's world frame (Sim(3) of its keyframes onto the ground truth).
slam::Map AlignToScene(const SlamRun& run, const std::string& what, double* rmse) {
  std::string problem;
  const auto alignment = privacy::AlignMapToGroundTruth(run.map, run.ground_truth, 0.02, &problem);
  if (!alignment) throw InputError(what, "cannot align the SLAM map to the ground truth: " + problem);
  *rmse = alignment->rmse;
  slam::Map aligned = privacy::TransformMap(run.map, alignment->gt_from_map);
  aligned.description = run.map.description + " | Sim(3)-aligned to the ground truth";
  return aligned;
}

struct DeskOutcome {
  SlamRun server, client;
  double server_rmse = 0.0;
  // The client's trajectory against the ground truth in the server's frame, no alignment.
  std::optional<mapping::TrajectoryErrorReport> client_ape;
  std::size_t lines = 0;
  privacy::AuditReport audit;
  const privacy::CheckOutcome* concealed = nullptr;
  // Step 7.
  bool merged = false;
  mapping::UploadMergeResult merge_upload;
  mapping::MapMergeReport merge_report;
  privacy::AuditReport merged_audit;
  std::size_t merged_lines = 0;
};

// Step 6: the Desk experiment (see the file comment).
void RunDesk(const std::string& out, int frames, std::uint64_t seed, DeskOutcome* desk) {
  render::SynthDatasetOptions synth;
  synth.scenario = "desk";
  synth.frames = frames;
  synth.seed = seed;
  synth.out_dir = out + "/desk";
  render::WriteSynthDataset(synth, &std::cerr);
  desk->server = RunSlam(synth.out_dir, "map", seed);
  const slam::Map server_points = AlignToScene(desk->server, synth.out_dir + "/map", &desk->server_rmse);
  mapping::WriteMap(server_points, out + "/desk_server_points.lcmap");
  mapping::LineCloudOptions publish;
  publish.seed = seed;
  mapping::WriteMap(mapping::ConvertToLineCloud(server_points, publish),
                    out + "/desk_line_cloud.lcmap");
  const slam::Map line_cloud = mapping::ReadMap(out + "/desk_line_cloud.lcmap");
  desk->lines = line_cloud.lines.size();
  // The LC-VSLAM client in the published line cloud: its map is in the server's frame (the
  // scene's, since the server map was aligned to it) only when it relocalized.
  desk->client = RunSlam(synth.out_dir, "client", seed, &line_cloud);
  const slam::Map& client_map = desk->client.map;
  mapping::WriteMap(client_map, out + "/desk_client_map.lcmap");
  mapping::WriteTrajectory(desk->client.trajectory, out + "/desk_client_trajectory.txt",
                           mapping::TrajectoryFormat::kTum);
  if (desk->client.stats.relocalized_in_line_cloud) {
    mapping::TrajectoryErrorOptions ape_options;
    ape_options.alignment = mapping::TrajectoryAlignment::kNone;
    desk->client_ape =
        mapping::ComputeApe(desk->client.ground_truth, desk->client.trajectory, ape_options);
    if (desk->client_ape->problem) desk->client_ape.reset();
  }
  const privacy::ConcealedSpec concealed =
      privacy::ReadSceneConcealedRegions(synth.out_dir + "/scene.json");
  privacy::AuditInputs inputs;
  inputs.map = &line_cloud;
  inputs.reference = &server_points;
  inputs.client = &client_map;
  inputs.concealed = &concealed;
  desk->audit = privacy::RunAudit(inputs, {}, &std::cerr);
  privacy::WriteAuditReport(&desk->audit, out + "/desk_audit.json");
  for (const privacy::CheckOutcome& c : desk->audit.checks) {
    if (c.name == "concealed") desk->concealed = &c;
  }
}

// Step 7: the map server's side (issue 13): the client's upload (its `--map-out`, converted to
// lines) merged into the server's line cloud (same frame, the privacy rule on lines through one
// point, global optimization with virtual observations), then audited.
void MergeClientUpload(const std::string& out, std::uint64_t seed, DeskOutcome* desk) {
  if (!desk->client.stats.relocalized_in_line_cloud) return;
  const slam::Map base = mapping::ReadMap(out + "/desk_line_cloud.lcmap");
  mapping::MapMergeOptions options;
  options.seed = seed;
  options.optimize = true;
  mapping::MapMerger merger(base, options);
  desk->merge_upload = merger.AddUpload(desk->client.map, out + "/desk_client_map.lcmap");
  mapping::MapMergeReport report;
  const slam::Map merged = merger.Finish(&report);
  desk->merge_report = report;
  mapping::WriteMap(merged, out + "/desk_merged.lcmap");
  privacy::AuditInputs inputs;
  inputs.map = &merged;
  desk->merged_audit = privacy::RunAudit(inputs, {}, &std::cerr);
  privacy::WriteAuditReport(&desk->merged_audit, out + "/desk_merged_audit.json");
  desk->merged_lines = merged.lines.size();
  desk->merged = true;
}

// shares[k] (RecoveryStats::fractions or ::precision) at the relative tolerance `value` (0.01 =
// 1% of the scene size); empty when the report did not measure it.
std::optional<double> ShareAtRelativeTolerance(const privacy::RecoveryStats& r,
                                               const std::vector<double>& shares, double value) {
  for (size_t k = 0; k < r.tolerances.size() && k < shares.size(); ++k) {
    if (r.tolerances[k].relative && r.tolerances[k].value == value) return shares[k];
  }
  return std::nullopt;
}

int RunDemo(int argc, char** argv) {
  ArgParser args("lcv demo [--out DIR] [--frames N] [--desk-frames N] [--seed N]",
                 "Runs the main job on built-in synthetic data: renders a street sequence with "
                 "ground truth,\nruns visual SLAM on it, publishes the map as a line cloud, "
                 "audits the line cloud and\nrenders snapshots; then the Desk experiment: SLAM "
                 "maps of a room whose privacy object\nis missing from the client sequence, "
                 "audited for concealed-object leaks (check 3).\nEverything is written to --out.",
                 "lcv demo --out /tmp/lcv-demo");
  args.AddOption("--out", "DIR", "folder for the results", "lcv-demo");
  args.AddOption("--frames", "N", "frames of the synthetic street sequence", "80");
  args.AddOption("--desk-frames", "N", "frames per sequence of the desk scene (0: skip it)", "60");
  args.AddOption("--seed", "N", "seed of the scene, the SLAM and the line directions", "1");
  if (!args.Parse(argc, argv)) return kExitOk;
  const std::string out = args.Get("--out");
  const std::uint64_t seed = args.GetSeed();
  const int frames = args.GetInt("--frames");
  const int desk_frames = args.GetInt("--desk-frames");
  if (frames < 20) throw UsageError("--frames: at least 20 frames are needed to initialize");
  if (desk_frames != 0 && desk_frames < 20) {
    throw UsageError("--desk-frames: 0 (skip) or at least 20 frames");
  }
  MakeDirectory(out);
  const auto start = std::chrono::steady_clock::now();
  const int stages = desk_frames > 0 ? 7 : 5;
  auto stage = [&](int k, const char* what) {
    std::cerr << "[demo " << k << "/" << stages << "] " << what << "\n";
  };

  stage(1, "rendering the synthetic street sequence");
  render::SynthDatasetOptions synth;
  synth.scenario = "tracking";
  synth.frames = frames;
  synth.seed = seed;
  synth.out_dir = out + "/scene";
  render::WriteSynthDataset(synth, &std::cerr);

  stage(2, "visual SLAM on the map sequence");
  SlamRun street = RunSlam(synth.out_dir, "map", seed);
  mapping::WriteTrajectory(street.trajectory, out + "/trajectory.txt",
                           mapping::TrajectoryFormat::kTum);
  const slam::Map& point_map = street.map;
  mapping::WriteMap(point_map, out + "/slam_map.lcmap");
  mapping::TrajectoryErrorOptions ape_options;
  ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
  const auto ape = mapping::ComputeApe(street.ground_truth, street.trajectory, ape_options);

  stage(3, "publishing the map behind the privacy gate (lcv map publish, default risk limits)");
  PublishGateOptions gate;
  gate.audit.fail_rules = privacy::ParseFailRules(privacy::kDefaultFailRules);
  gate.seed = seed;
  PublishGateResult gated = RunPublishGate(point_map, gate, &std::cerr);
  // Stage 4 is the gate's last audit: the line cloud is written only when it passes.
  stage(4, "audit of the published line cloud (the gate's last round)");
  privacy::AuditReport& audit = gated.audit;
  privacy::WriteAuditReport(&audit, out + "/audit.json");
  if (audit.passed) mapping::WriteMap(gated.lines, out + "/line_cloud.lcmap");
  const slam::Map line_cloud =
      audit.passed ? mapping::ReadMap(out + "/line_cloud.lcmap") : gated.lines;

  stage(5, "rendering snapshots");
  WriteSnapshot(point_map, render::SnapshotView::kTop, out + "/slam_map.png");
  WriteSnapshot(line_cloud, render::SnapshotView::kOblique, out + "/line_cloud.png");

  DeskOutcome desk;
  if (desk_frames > 0) {
    stage(6, "desk scene: server line cloud, LC-VSLAM client in it, concealed-object audit");
    RunDesk(out, desk_frames, seed, &desk);
    stage(7, "desk scene: the client's upload merged into the server's line cloud, audited");
    MergeClientUpload(out, seed, &desk);
  }

  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("scene:       %s (%d frames, ground truth)\n", synth.out_dir.c_str(), street.frames);
  std::printf("slam:        %d/%d frames tracked, %d keyframes, %zu points\n", street.tracked,
              street.frames, street.keyframes, point_map.points.size());
  if (ape.problem) {
    std::printf("APE:         not computed: %s\n", ape.problem->c_str());
  } else {
    std::printf("APE (Sim3):  translation RMSE %.3f m over %d poses\n", ape.translation.rmse,
                ape.matched);
  }
  std::printf("line cloud:  %zu of %zu lines kept by the gate (%zu rounds), %zu server keyframes, "
              "published: %s\n",
              line_cloud.lines.size(), gated.converted_lines, gated.rounds.size() - 1,
              line_cloud.server_keyframes.size(),
              audit.passed && slam::IsPublishedLineCloud(line_cloud) ? "yes" : "NO");
  std::printf("audit:       %s under the default risk limits %s -> %s/audit.json\n",
              audit.passed ? "passed" : "FAILED", privacy::kDefaultFailRules, out.c_str());
  // Recovered shares at 1% (the default limits' tolerance) and 5% of the scene size.
  std::string recovered;
  for (const privacy::AttackOutcome& attack : audit.attacks) {
    if (!attack.recovery) continue;
    const auto& r = *attack.recovery;
    const std::optional<double> at1 = ShareAtRelativeTolerance(r, r.fractions, 0.01);
    const std::optional<double> at5 = ShareAtRelativeTolerance(r, r.fractions, 0.05);
    if (!at1 || !at5) continue;
    char buffer[96];
    std::snprintf(buffer, sizeof buffer, "%s%s %.1f%% / %.1f%%", recovered.empty() ? "" : ", ",
                  attack.result.name.c_str(), 100.0 * *at1, 100.0 * *at5);
    recovered += buffer;
  }
  if (!recovered.empty()) {
    std::printf("attacks:     hidden points recovered within 1%% / 5%% of the scene size: %s\n",
                recovered.c_str());
  }
  std::printf("snapshots:   %s/slam_map.png %s/line_cloud.png\n", out.c_str(), out.c_str());
  bool passed = audit.passed;
  if (desk_frames > 0) {
    const slam::SystemStats& client = desk.client.stats;
    int restored = 0;
    for (const auto& [id, line] : desk.client.map.lines) restored += line.restored_point.has_value();
    std::printf("desk:        server %d/%d frames tracked, aligned to the scene (keyframe RMSE "
                "%.4f m), published as %zu lines\n",
                desk.server.tracked, desk.server.frames, desk.server_rmse, desk.lines);
    if (client.relocalized_in_line_cloud) {
      const double start = desk.client.ground_truth.poses.empty()
                               ? 0.0 : desk.client.ground_truth.poses.front().timestamp;
      std::printf("lc-vslam:    client %d/%d frames tracked in the line cloud, relocalized at "
                  "%.2f s (%s, %d inliers), %zu points X, %d restored X'\n",
                  desk.client.tracked, desk.client.frames,
                  client.line_cloud_registration_timestamp - start,
                  client.line_cloud_method.c_str(), client.line_cloud_inliers,
                  desk.client.map.points.size(), restored);
      // The accuracy of the X' against the hidden points the server kept (the audit's "client").
      for (const privacy::AttackOutcome& attack : desk.audit.attacks) {
        if (attack.result.name != "client" || !attack.recovery) continue;
        const auto& r = *attack.recovery;
        if (const std::optional<double> at1 = ShareAtRelativeTolerance(r, r.precision, 0.01)) {
          std::printf("             X' on their hidden point within 1%% of the scene size: %.1f%% "
                      "(median error %.3g m)\n",
                      100.0 * *at1, r.median_estimate_error_m);
        }
      }
      if (desk.client_ape) {
        std::printf("             APE in the server's frame (no alignment): translation RMSE "
                    "%.4f m, rotation RMSE %.2f deg over %d poses\n",
                    desk.client_ape->translation.rmse, desk.client_ape->rotation_deg.rmse,
                    desk.client_ape->matched);
      }
    } else {
      std::printf("lc-vslam:    client %d/%d frames tracked, NOT relocalized in the line cloud "
                  "(%s): its map is in its own frame\n",
                  desk.client.tracked, desk.client.frames, client.line_cloud_last_failure.c_str());
    }
    if (desk.concealed && !desk.concealed->skipped) {
      const auto& d = desk.concealed->details;
      std::printf("concealed:   %s: %d client points X and %d X' vs %d lines of the concealed "
                  "object (epsilon %.3g m), %d violations\n",
                  desk.concealed->passed ? "passed" : "FAILED",
                  d.value("client_points_checked", 0), d.value("restored_points_checked", 0),
                  d.value("concealed_lines", 0),
                  d.value("epsilon_m", 0.0), static_cast<int>(d.value("violations", nlohmann::json::array()).size()));
      if (const int cleared = d.value("points_cleared_by_observations", 0); cleared > 0) {
        std::printf("             %d client point(s) X near a concealed line cleared: their own "
                    "observations also place them outside it (docs/audit.md)\n",
                    cleared);
      }
    } else {
      std::printf("concealed:   not run (no concealed object in the scene)\n");
    }
    // The Desk experiment reproduces the paper's plain conversion: its audits judge the
    // concealed object, formats and duplicates, without risk limits (lcv map publish adds them).
    std::printf("desk audit:  %s (concealed object, no risk limits) -> %s/desk_audit.json\n",
                desk.audit.passed ? "passed" : "FAILED", out.c_str());
    passed = passed && desk.audit.passed && client.relocalized_in_line_cloud;
    if (desk.merged) {
      std::printf("merge:       client upload %s (%s frame): %d lines added, %d dropped by the "
                  "privacy rule (lines through one point), %zu lines published\n",
                  desk.merge_upload.accepted ? "accepted" : "REJECTED",
                  desk.merge_upload.frame.c_str(), desk.merge_upload.lines_added,
                  desk.merge_report.lines_dropped, desk.merged_lines);
      std::printf("merged audit: %s (no risk limits) -> %s/desk_merged_audit.json\n",
                  desk.merged_audit.passed ? "passed" : "FAILED", out.c_str());
      passed = passed && desk.merge_upload.accepted && desk.merged_audit.passed;
    }
  }
  std::printf("time:        %.1f s\n", seconds);
  return passed ? kExitOk : kExitCheckFailed;
}

}  // namespace
LCV_REGISTER_COMMAND("demo", "run the main job on built-in synthetic data", RunDemo);
}  // namespace lcv::apps
