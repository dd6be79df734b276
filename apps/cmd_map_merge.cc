// `lcv map merge|optimize`: the map server's curation of uploaded line clouds
// (mapping/map_merge.h, mapping/merge_optimization.h, docs/curation.md).
#include <chrono>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/map_file.h"
#include "mapping/map_merge.h"
#include "mapping/merge_optimization.h"
#include "slam/geometry/so3.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using nlohmann::json;

json Sim3Json(const slam::Sim3d& S) {
  const Eigen::Quaterniond& q = S.rotation;
  return json{{"scale", S.scale},
              {"rotation_wxyz", {q.w(), q.x(), q.y(), q.z()}},
              {"translation", {S.translation.x(), S.translation.y(), S.translation.z()}}};
}

json OptimizationJson(const mapping::MergeOptimizationReport& r) {
  return json{{"success", r.success},
              {"server_keyframes", r.num_server_keyframes},
              {"lines", r.num_lines},
              {"observed_copies", r.num_copies},
              {"virtual_observations", r.num_virtual_observations},
              {"iterations", r.num_iterations},
              {"cost_before", r.cost_before},
              {"cost_after", r.cost_after},
              {"seconds", r.seconds},
              {"message", r.message}};
}

void AddOptimizationOptions(ArgParser* args) {
  args->AddOption("--omega-vl", "MODE",
                  "information of the virtual observations: propagated (from Omega_L) | constant",
                  "propagated");
  args->AddOption("--virtual-sigma", "RAD",
                  "sigma of the virtual observations (constant mode), and the floor of the "
                  "propagated one, radians",
                  "0.002");
  args->AddOption("--huber", "K", "Huber threshold on whitened virtual residuals (0: none)", "2");
  args->AddOption("--iterations", "N", "Ceres iterations", "30");
}

mapping::MergeOptimizationOptions OptimizationOptionsFrom(const ArgParser& args) {
  mapping::MergeOptimizationOptions o;
  const std::string mode = args.Get("--omega-vl");
  if (mode != "propagated" && mode != "constant") {
    throw UsageError("--omega-vl: '" + mode + "' is not one of propagated, constant");
  }
  o.propagate_information = mode == "propagated";
  o.virtual_sigma_rad = args.GetDouble("--virtual-sigma");
  o.huber_delta = args.GetDouble("--huber");
  o.max_iterations = args.GetInt("--iterations");
  if (const std::string p = o.Problem(); !p.empty()) throw UsageError(p);
  return o;
}

int RunMapMerge(int argc, char** argv) {
  ArgParser args(
      "lcv map merge BASE UPLOAD... --out MERGED [--optimize] [--report FILE.json] "
      "[--frame auto|same|independent]",
      "Merges line clouds uploaded by clients into the base line cloud BASE.\n"
      "Same-frame uploads (made by a client relocalized in BASE: they refer to its line ids)\n"
      "join directly: their server keyframes are added, base lines they saw again gain\n"
      "visibility, their new lines get fresh ids. Uploads in a frame of their own are first\n"
      "registered by a Sim(3) between the two line clouds (descriptor matches, RANSAC on\n"
      "line-line intersections, refinement) and rejected with the reason when that fails.\n"
      "Privacy rule: two lines through one point (descriptor match, near-intersection,\n"
      "consistent visibility) are never both kept. --optimize adjusts the uploaded server\n"
      "keyframes and lines on their virtual observations, the base map held fixed.\n"
      "An unreadable or unrelated upload is reported and skipped. MERGED and the report are\n"
      "written only when the merge finished (temporary name, then rename). Uploads that still\n"
      "hold points are converted to lines first (--seed). Progress: one line per upload on\n"
      "stderr.",
      "lcv map merge server.lcmap client_a.lcmap client_b.lcmap --out merged.lcmap --optimize "
      "--report merge.json");
  args.AddPositional("BASE", "base line cloud (.lcmap or .json)");
  args.AddPositionalList("UPLOAD", "uploaded line clouds or client maps, one or more");
  args.AddOption("--out", "MERGED", "merged line cloud to write (required)");
  args.AddSwitch("--optimize", "optimize the merged map globally (see lcv map optimize)");
  args.AddOption("--report", "FILE", "JSON report (uploads[] in the order given)");
  args.AddOption("--frame", "MODE", "auto | same | independent: how uploads relate to BASE",
                 "auto");
  args.AddOption("--inlier-distance", "D",
                 "registration inlier distance between lines, map units (0: 0.3% of the base's "
                 "camera extent)",
                 "0");
  args.AddOption("--min-inliers", "N", "registration: fewest inliers accepted", "30");
  args.AddOption("--max-trials", "N", "registration: RANSAC trials", "5000");
  args.AddOption("--seed", "N", "RANSAC and conversion seed", "0");
  AddOptimizationOptions(&args);
  if (!args.Parse(argc, argv)) return kExitOk;
  const auto start = std::chrono::steady_clock::now();
  const std::string base_path = args.Positional("BASE");
  const std::vector<std::string> uploads = args.PositionalList("UPLOAD");
  const std::string out = args.Get("--out");
  if (out.empty()) throw UsageError("empty --out");

  mapping::MapMergeOptions options;
  const std::string frame = args.Get("--frame");
  if (frame == "auto") options.frame = mapping::UploadFrame::kAuto;
  else if (frame == "same") options.frame = mapping::UploadFrame::kSame;
  else if (frame == "independent") options.frame = mapping::UploadFrame::kIndependent;
  else throw UsageError("--frame: '" + frame + "' is not one of auto, same, independent");
  options.registration.inlier_distance = args.GetDouble("--inlier-distance");
  options.registration.min_inliers = args.GetInt("--min-inliers");
  options.registration.max_trials = args.GetInt("--max-trials");
  options.registration.seed = args.GetSeed();
  options.seed = args.GetSeed();
  options.optimize = args.Has("--optimize");
  options.optimization = OptimizationOptionsFrom(args);
  if (const std::string p = options.Problem(); !p.empty()) throw UsageError(p);

  std::cerr << "map merge: reading base " << base_path << "\n";
  const slam::Map base = mapping::ReadMap(base_path);
  mapping::MapMerger merger(base, options);
  const std::size_t base_lines = merger.map().lines.size();
  std::size_t total_lines = base_lines;
  for (std::size_t i = 0; i < uploads.size(); ++i) {
    const auto upload_start = std::chrono::steady_clock::now();
    mapping::UploadMergeResult result;
    try {
      const slam::Map upload = mapping::ReadMap(uploads[i]);
      total_lines += upload.lines.size() + upload.points.size();
      result = merger.AddUpload(upload, uploads[i]);
    } catch (const InputError& e) {
      merger.AddRejected(uploads[i], std::string("unreadable: ") + e.what());
      result.reason = std::string("unreadable: ") + e.what();
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - upload_start).count();
    std::fprintf(stderr,
                 "map merge: [%zu/%zu] %s: %s%s%s, +%d lines, %d merged, %d keyframes "
                 "(%.1f s; map %zu lines)\n",
                 i + 1, uploads.size(), uploads[i].c_str(),
                 result.accepted ? "accepted (" : "rejected: ",
                 result.accepted ? result.frame.c_str() : result.reason.c_str(),
                 result.accepted ? ")" : "", result.lines_added, result.lines_merged,
                 result.server_keyframes_added, seconds, merger.map().lines.size());
  }
  std::cerr << "map merge: privacy rule" << (options.optimize ? ", optimization" : "") << "\n";
  mapping::MapMergeReport report;
  slam::Map merged = merger.Finish(&report);
  merged.description = (base.description.empty() ? "" : base.description + " | ") +
                       "lcv map merge of " + std::to_string(uploads.size()) + " uploads";
  mapping::ValidateMap(merged, out);
  LCV_CHECK(slam::IsPublishedLineCloud(merged)) << "merge left private data";
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  int accepted = 0;
  json uploads_json = json::array();
  for (const mapping::UploadMergeResult& u : report.uploads) {
    accepted += u.accepted;
    uploads_json.push_back(
        json{{"file", u.name},
             {"accepted", u.accepted},
             {"reason", u.reason},
             {"frame", u.frame.empty() ? json(nullptr) : json(u.frame)},
             {"sim3", u.base_from_upload ? Sim3Json(*u.base_from_upload) : json(nullptr)},
             {"server_keyframes_added", u.server_keyframes_added},
             {"lines_added", u.lines_added},
             {"lines_merged", u.lines_merged},
             {"lines_dropped", u.lines_dropped},
             {"registration_candidates", u.registration_candidates},
             {"registration_inliers", u.registration_inliers}});
  }
  const json report_json{
      {"base", base_path},
      {"out", out},
      {"uploads", uploads_json},
      {"base_lines", base_lines},
      {"lines", merged.lines.size()},
      {"server_keyframes", merged.server_keyframes.size()},
      {"duplicate_groups", report.duplicate_groups},
      {"lines_dropped", report.lines_dropped},
      {"optimization", report.optimization ? OptimizationJson(*report.optimization) : json(nullptr)},
      {"cost_before", report.optimization ? json(report.optimization->cost_before) : json(nullptr)},
      {"cost_after", report.optimization ? json(report.optimization->cost_after) : json(nullptr)},
      {"seconds", report.seconds}};
  // The map first: a report never describes a map that was not written.
  mapping::WriteMap(merged, out);
  if (auto path = args.GetOptional("--report")) {
    mapping::WriteFileAtomically(*path, report_json.dump(2) + "\n");
  }
  std::printf("merged %d of %zu uploads into %s: %zu -> %zu lines, %zu server keyframes\n",
              accepted, uploads.size(), base_path.c_str(), base_lines, merged.lines.size(),
              merged.server_keyframes.size());
  std::printf("privacy rule: %d lines dropped (%d groups of lines through one point)\n",
              report.lines_dropped, report.duplicate_groups);
  if (report.optimization) {
    std::printf("optimization: cost %.6g -> %.6g in %d iterations\n",
                report.optimization->cost_before, report.optimization->cost_after,
                report.optimization->num_iterations);
  }
  std::printf("wrote %s (%.1f s, %zu lines read in total)\n", out.c_str(), report.seconds,
              total_lines);
  return kExitOk;
}

int RunMapOptimize(int argc, char** argv) {
  ArgParser args(
      "lcv map optimize MAP --out MAP2 [--report FILE.json]",
      "Global optimization of a line cloud's server keyframe poses and lines on the virtual\n"
      "observations e_vL (paper eq. 5) of every line by every server keyframe that sees it,\n"
      "taken from MAP's current state, with a Huber loss and Omega_vL propagated from\n"
      "Omega_L. Gauge: the --fixed-keyframes server keyframes with the smallest ids. A map\n"
      "that agrees with itself is left (nearly) unchanged: the corrections come from merging,\n"
      "where each upload's own observations are kept (lcv map merge --optimize).",
      "lcv map optimize merged.lcmap --out merged_opt.lcmap --report optimize.json");
  args.AddPositional("MAP", "line cloud (.lcmap or .json)");
  args.AddOption("--out", "MAP2", "optimized line cloud to write (required)");
  args.AddOption("--report", "FILE", "JSON report");
  args.AddOption("--fixed-keyframes", "N", "server keyframes held fixed (gauge), >= 2", "2");
  AddOptimizationOptions(&args);
  if (!args.Parse(argc, argv)) return kExitOk;
  const std::string in = args.Positional("MAP");
  const std::string out = args.Get("--out");
  const int num_fixed = args.GetInt("--fixed-keyframes");
  if (num_fixed < 2) throw UsageError("--fixed-keyframes must be >= 2 (scale gauge)");
  const mapping::MergeOptimizationOptions options = OptimizationOptionsFrom(args);
  std::cerr << "map optimize: reading " << in << "\n";
  slam::Map map = mapping::ReadMap(in);
  if (!map.keyframes.empty() || !map.points.empty()) {
    throw InputError(in, "holds client keyframes or points: optimize line clouds only "
                         "(convert with lcv map convert --to-lines)");
  }
  std::set<slam::Id> fixed;
  for (const auto& [id, kf] : map.server_keyframes) {
    if (static_cast<int>(fixed.size()) < num_fixed) fixed.insert(id);
  }
  const mapping::MergeOptimizationReport report = mapping::OptimizeLineCloud(
      options, mapping::VirtualObservationsOf(map), {}, fixed, {}, &map);
  if (!report.success) throw InputError(in, "optimization failed: " + report.message);
  mapping::ValidateMap(map, out);
  mapping::WriteMap(map, out);
  if (auto path = args.GetOptional("--report")) {
    json j = OptimizationJson(report);
    j["map"] = in;
    j["out"] = out;
    mapping::WriteFileAtomically(*path, j.dump(2) + "\n");
  }
  std::printf("optimized %s: %d server keyframes, %d lines, %d virtual observations\n",
              in.c_str(), report.num_server_keyframes, report.num_lines,
              report.num_virtual_observations);
  std::printf("cost %.6g -> %.6g in %d iterations (%.1f s)\n", report.cost_before,
              report.cost_after, report.num_iterations, report.seconds);
  std::printf("wrote %s\n", out.c_str());
  return kExitOk;
}

}  // namespace

LCV_REGISTER_COMMAND("map merge", "merge uploaded line clouds into a base line cloud", RunMapMerge);
LCV_REGISTER_COMMAND("map optimize", "global optimization of a line cloud (virtual observations)",
                     RunMapOptimize);

}  // namespace lcv::apps
