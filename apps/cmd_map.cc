// `lcv map import|convert|info|export|transform|compare`: the map curator's commands (map files:
// mapping/io).
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/colmap.h"
#include "mapping/io/map_file.h"
#include "mapping/io/point_cloud_export.h"
#include "mapping/io/trajectory.h"
#include "mapping/line_cloud.h"
#include "mapping/map_compare.h"
#include "privacy/audit.h"
#include "privacy/map_alignment.h"
#include "privacy/map_ground_truth_poses.h"
#include "privacy/mitigation.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using nlohmann::json;

void CheckMapOutputPath(const std::string& path) {
  if (path.empty()) throw UsageError("empty output path");
}

const char* EncodingName(mapping::MapEncoding encoding) {
  return encoding == mapping::MapEncoding::kJson ? "JSON" : "MessagePack";
}

// ---------------------------------------------------------------------------------------------

int RunMapImport(int argc, char** argv) {
  ArgParser args("lcv map import --colmap DIR OUT",
                 "Imports a COLMAP sparse model in text form (DIR/cameras.txt, images.txt,\n"
                 "points3D.txt; `colmap model_converter --output_type TXT`) as a point map.\n"
                 "Camera models: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV,\n"
                 "FULL_OPENCV (k4 = k5 = k6 = 0) -> perspective; OPENCV_FISHEYE -> fisheye.\n"
                 "Ids are offset to be unique map-wide: keyframe = IMAGE_ID + max CAMERA_ID,\n"
                 "point = POINT3D_ID + max CAMERA_ID + max IMAGE_ID (recorded in the map's\n"
                 "description). Point covariances come from the tracks (see mapping/io/colmap.h).\n"
                 "OUT ending in .json is written as JSON, anything else as MessagePack (.lcmap).",
                 "lcv map import --colmap /tmp/kitti00_colmap/sparse_txt kitti00_points.lcmap");
  args.AddOption("--colmap", "DIR", "folder of the COLMAP text model (required)");
  args.AddOption("--min-sigma-px", "PX", "floor of the per-point pixel sigma", "0.5");
  args.AddOption("--prior-sigma-scale", "S",
                 "prior sigma of every point = S x median camera-to-point distance", "10");
  args.AddPositional("OUT", "output map file (.lcmap or .json)");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"OUT"});  // before any work
  mapping::ColmapImportOptions options;
  options.min_sigma_px = args.GetDouble("--min-sigma-px");
  options.prior_sigma_scale = args.GetDouble("--prior-sigma-scale");
  if (!(options.min_sigma_px > 0)) throw UsageError("--min-sigma-px must be > 0");
  if (!(options.prior_sigma_scale > 0)) throw UsageError("--prior-sigma-scale must be > 0");
  const std::string dir = args.Get("--colmap");
  const std::string out = args.Positional("OUT");
  CheckMapOutputPath(out);

  std::cerr << "map import: reading COLMAP text model " << dir << "\n";
  slam::Map map = mapping::ReadColmapTextModel(dir, options);
  map.description = "lcv map import --colmap: " + map.description;
  std::size_t observations = 0;
  for (const auto& [id, p] : map.points) observations += p.observations.size();
  std::cerr << "map import: writing " << out << "\n";
  mapping::WriteMap(map, out);
  std::printf("imported %s: %zu cameras, %zu keyframes, %zu points, %zu observations\n",
              dir.c_str(), map.cameras.size(), map.keyframes.size(), map.points.size(),
              observations);
  std::printf("wrote %s (%s)\n", out.c_str(), EncodingName(mapping::EncodingForPath(out)));
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------

int RunMapConvert(int argc, char** argv) {
  ArgParser args(
      "lcv map convert --to-lines IN OUT [--seed N] [--information proxy|covariance]\n"
      "                [--mitigate drop|rerandomize [--fraction F] [--risk REPORT]]\n"
      "       lcv map convert --copy IN OUT",
      "The publishing step: converts a point map into a line cloud (paper Sec. 3.4).\n"
      "Each point becomes a line with the same id through it, with a direction drawn\n"
      "uniformly on the sphere from the seed (independent of the scene) and the information\n"
      "matrix Omega_L = ((I - d d^T) Sigma (I - d d^T))^+ (eq. 1), Sigma by default that of a\n"
      "point triangulated from the line's server keyframes at the line's point closest to\n"
      "them (published data only; --information covariance: the point's own covariance,\n"
      "whose size gives the point's distance away, docs/audit.md).\n"
      "The anchor is re-drawn as the point of the line closest to the map origin, a function\n"
      "of the line alone, so it says nothing about where on the line the point was.\n"
      "Points closer than 5e-5 of the points' median spread are merged into one first (their lines\n"
      "would cross exactly there). Client keyframes become server keyframes (pose and\n"
      "visible line ids only); every\n"
      "keypoint, observation and restored point is dropped; descriptors are kept.\n"
      "Convert a map once: two line clouds of the same points with different directions\n"
      "intersect at the points. OUT is checked to be a published line cloud.\n\n"
      "Mitigation (audit check 5): --mitigate drops, or re-randomizes the direction of, the\n"
      "--fraction of lines the privacy attacks score riskiest (risk from --risk, an audit report\n"
      "or risk CSV of this conversion; without it the density, visibility and duplicate attacks\n"
      "run on the converted cloud). Re-randomized lines turn about their true hidden point, so\n"
      "they still pass through it. The lines are chosen within direction cells (--direction-bands)\n"
      "so that what is kept stays uniform in direction. Audit the result to measure the effect.\n\n"
      "--copy writes IN unchanged in OUT's encoding (.json readable JSON, any other name\n"
      "MessagePack), e.g. to read a .lcmap with a JSON tool; nothing is published.",
      "lcv map convert --to-lines points.lcmap published.lcmap --seed 7 --mitigate drop "
      "--fraction 0.2\n  lcv map convert --copy client_map.lcmap client_map.json");
  args.AddSwitch("--to-lines", "convert points to lines (the publishing step)");
  args.AddSwitch("--copy", "write IN unchanged in OUT's encoding (JSON <-> MessagePack)");
  args.AddOption("--seed", "N", "seed of the random line directions", "0");
  args.AddOption("--information", "RULE",
                 "each line's Omega_L: proxy (eq. 1 at a point the published line and keyframes "
                 "determine) | covariance (eq. 1 from the point's own covariance; reveals the "
                 "point's distance from a keyframe, see mapping/line_cloud.h)",
                 "proxy");
  args.AddOption("--mitigate", "MODE", "drop | rerandomize the riskiest lines (default: none)");
  args.AddOption("--fraction", "F", "share of the lines to mitigate, in [0, 1]", "0.1");
  args.AddOption("--direction-bands", "B",
                 "riskiest lines chosen per direction cell (2 B^2 cells); 0: global ranking",
                 "8");
  args.AddOption("--risk", "FILE",
                 "per-line risk: an audit report JSON or a line_id,risk CSV (default: run the "
                 "attacks)");
  args.AddPositional("IN", "point map (.lcmap or .json)");
  args.AddPositional("OUT", "line cloud to write (.lcmap or .json)");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"OUT"});  // before any work
  if (args.Has("--to-lines") == args.Has("--copy")) {
    throw UsageError("choose one conversion: --to-lines (publish) or --copy (re-encode)");
  }
  const std::string in = args.Positional("IN");
  const std::string out = args.Positional("OUT");
  CheckMapOutputPath(out);
  if (args.Has("--copy")) {
    if (args.GetOptional("--mitigate") || args.GetOptional("--risk")) {
      throw UsageError("--copy writes the map unchanged: no --mitigate or --risk");
    }
    const slam::Map map = mapping::ReadMap(in);
    mapping::ValidateMap(map, out);
    mapping::WriteMap(map, out);
    std::printf("copied %s -> %s (%s, unchanged%s)\n", in.c_str(), out.c_str(),
                EncodingName(mapping::EncodingForPath(out)),
                slam::IsPublishedLineCloud(map) ? "" : "; not a published line cloud");
    return kExitOk;
  }
  mapping::LineCloudOptions options;
  options.seed = args.GetSeed();
  const std::string information = args.Get("--information");
  if (information == "proxy") {
    options.information = mapping::LineInformationRule::kProxyPoint;
  } else if (information == "covariance") {
    options.information = mapping::LineInformationRule::kPointCovariance;
  } else {
    throw UsageError("--information: '" + information + "' is not one of proxy, covariance");
  }

  std::cerr << "map convert: reading " << in << "\n";
  const slam::Map points = mapping::ReadMap(in);
  if (points.points.empty()) {
    std::cerr << "map convert: warning: " << in << " has no points; only existing lines are kept\n";
  }
  mapping::LineCloudReport conversion;
  slam::Map lines = mapping::ConvertToLineCloud(points, options, &conversion);
  lines.description = (points.description.empty() ? "" : points.description + " | ") +
                      "lcv map convert --to-lines --seed " + std::to_string(options.seed) +
                      " --information " + information;
  std::optional<privacy::MitigationReport> mitigation;
  if (auto mode = args.GetOptional("--mitigate")) {
    privacy::MitigationOptions mitigate;
    if (*mode == "drop") {
      mitigate.mode = privacy::MitigationMode::kDrop;
    } else if (*mode == "rerandomize") {
      mitigate.mode = privacy::MitigationMode::kRerandomize;
    } else {
      throw UsageError("--mitigate: '" + *mode + "' is not one of drop, rerandomize");
    }
    mitigate.fraction = args.GetDouble("--fraction");
    if (!(mitigate.fraction >= 0.0 && mitigate.fraction <= 1.0)) {
      throw UsageError("--fraction: must be in [0, 1]");
    }
    mitigate.seed = options.seed + 1;  // not the conversion's directions
    mitigate.direction_bands = args.GetInt("--direction-bands");
    if (mitigate.direction_bands < 0 || mitigate.direction_bands > 64) {
      throw UsageError("--direction-bands: must be in [0, 64]");
    }
    std::map<slam::Id, double> risk;
    if (auto risk_file = args.GetOptional("--risk")) {
      risk = privacy::ReadRisks(*risk_file);
    } else {
      std::cerr << "map convert: scoring the lines with the privacy attacks\n";
      privacy::AuditInputs inputs;
      inputs.map = &lines;
      const privacy::AuditReport audit = privacy::RunAudit(inputs, {}, &std::cerr);
      std::vector<privacy::LineAttackResult> attacks;
      for (const privacy::AttackOutcome& a : audit.attacks) attacks.push_back(a.result);
      risk = privacy::CombineRisks(attacks);
    }
    // The converter still has the points: re-randomized lines turn about the hidden point itself.
    std::map<slam::Id, Eigen::Vector3d> pivots;
    for (const auto& [id, point] : points.points) pivots[id] = point.position;
    privacy::MitigationReport report;
    lines = privacy::MitigateRiskiestLines(lines, risk, pivots, mitigate, &report);
    mitigation = report;
    mapping::ReapplyInformationRule(options, &lines);
  }
  LCV_CHECK(slam::IsPublishedLineCloud(lines)) << "conversion left private data";
  mapping::ValidateMap(lines, out);
  std::cerr << "map convert: writing " << out << "\n";
  mapping::WriteMap(lines, out);
  std::printf(
      "converted %s: %zu points -> %zu lines, %zu keyframes -> %zu server keyframes (seed %llu)\n",
      in.c_str(), points.points.size(), lines.lines.size(), points.keyframes.size(),
      lines.server_keyframes.size(), static_cast<unsigned long long>(options.seed));
  std::printf("coincident points merged before drawing lines: %d (in %d groups)\n",
              conversion.points_merged_away, conversion.coincident_groups);
  if (mitigation) {
    std::printf("mitigation: %s %d of %d lines (risk >= %.3f)\n", args.Get("--mitigate").c_str(),
                mitigation->num_changed, mitigation->num_lines, mitigation->risk_threshold);
  }
  std::printf("wrote %s (%s, published line cloud)\n", out.c_str(),
              EncodingName(mapping::EncodingForPath(out)));
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------

struct Bounds {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = -Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  std::size_t count = 0;
  void Add(const Eigen::Vector3d& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
    ++count;
  }
  json ToJson() const {
    if (!count) return nullptr;
    return json{{"min", {min.x(), min.y(), min.z()}}, {"max", {max.x(), max.y(), max.z()}}};
  }
  std::string ToText() const {
    if (!count) return "(none)";
    char buffer[160];
    std::snprintf(buffer, sizeof(buffer), "[%.3f, %.3f, %.3f] .. [%.3f, %.3f, %.3f]", min.x(),
                  min.y(), min.z(), max.x(), max.y(), max.z());
    return buffer;
  }
};

int RunMapInfo(int argc, char** argv) {
  ArgParser args("lcv map info MAP [--json]",
                 "Reads and validates a map file and prints its schema, encoding, counts,\n"
                 "bounds and whether it is a published line cloud (no client keyframes, points,\n"
                 "restored points or client observations). A corrupt file is reported with the\n"
                 "problem and exit code 1.",
                 "lcv map info published.lcmap --json");
  args.AddSwitch("--json", "print one JSON object instead of text");
  args.AddPositional("MAP", "map file (.lcmap or .json; the encoding is detected)");
  if (!args.Parse(argc, argv)) return kExitOk;
  const std::string path = args.Positional("MAP");
  const std::string bytes = mapping::ReadMapBytes(path);
  const slam::Map map = mapping::ParseMap(bytes, path);
  const std::size_t first = bytes.find_first_not_of(" \t\r\n");
  const bool is_json = first != std::string::npos && bytes[first] == '{';

  std::size_t keypoints = 0, point_observations = 0, line_observations = 0, restored = 0;
  std::size_t visibility = 0;
  Bounds landmarks, cameras;
  for (const auto& [id, kf] : map.keyframes) {
    keypoints += kf.keypoints.size();
    cameras.Add(kf.cam_from_world.Center());
  }
  for (const auto& [id, kf] : map.server_keyframes) cameras.Add(kf.cam_from_world.Center());
  for (const auto& [id, p] : map.points) {
    point_observations += p.observations.size();
    landmarks.Add(p.position);
  }
  for (const auto& [id, l] : map.lines) {
    line_observations += l.observations.size();
    restored += l.restored_point.has_value();
    visibility += l.server_keyframe_ids.size();
    landmarks.Add(l.line.anchor);
  }
  const bool published = slam::IsPublishedLineCloud(map);

  if (args.Has("--json")) {
    const json out{{"file", path},
                   {"encoding", is_json ? "json" : "msgpack"},
                   {"schema_version", mapping::kMapSchemaVersion},
                   {"bytes", bytes.size()},
                   {"description", map.description},
                   {"cameras", map.cameras.size()},
                   {"keyframes", map.keyframes.size()},
                   {"keypoints", keypoints},
                   {"server_keyframes", map.server_keyframes.size()},
                   {"points", map.points.size()},
                   {"point_observations", point_observations},
                   {"lines", map.lines.size()},
                   {"line_visibility", visibility},
                   {"restored_points", restored},
                   {"line_observations", line_observations},
                   {"published", published},
                   {"bounds", landmarks.ToJson()},
                   {"camera_bounds", cameras.ToJson()}};
    std::cout << out.dump(-1, ' ', false, json::error_handler_t::replace) << "\n";
    return kExitOk;
  }
  std::printf("%s: lcv map, schema %d, %s, %zu bytes\n", path.c_str(), mapping::kMapSchemaVersion,
              is_json ? "JSON" : "MessagePack", bytes.size());
  if (!map.description.empty()) {
    std::string d = map.description;
    if (d.size() > 160) d = d.substr(0, 157) + "...";
    std::printf("description: %s\n", d.c_str());
  }
  std::printf("cameras %zu, keyframes %zu (%zu keypoints), server keyframes %zu\n",
              map.cameras.size(), map.keyframes.size(), keypoints, map.server_keyframes.size());
  std::printf("points %zu (%zu observations), lines %zu (%zu restored points, %zu observations)\n",
              map.points.size(), point_observations, map.lines.size(), restored, line_observations);
  std::printf("bounds of points and line anchors: %s\n", landmarks.ToText().c_str());
  std::printf("bounds of camera centres: %s\n", cameras.ToText().c_str());
  std::printf("published line cloud: %s\n", published ? "yes" : "no");
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------

int RunMapExport(int argc, char** argv) {
  ArgParser args(
      "lcv map export MAP OUT.{ply,pcd} [--ascii] [--line-length L] [--samples-per-line N] "
      "[--cameras]",
      "Exports a map's geometry for CloudCompare, MeshLab or ParaView. Points are white\n"
      "vertices; each line is a segment of length L centred on its anchor (orange): in PLY\n"
      "its two end vertices joined by an `edge` element, in PCD a polyline of N samples.\n"
      "With --cameras the keyframe and server keyframe centres are added (red). The format\n"
      "follows OUT's extension: .ply or .pcd.",
      "lcv map export published.lcmap published.ply --line-length 0.5");
  args.AddSwitch("--ascii", "write ASCII instead of binary data");
  args.AddOption("--line-length", "L",
                 "segment length in map units (0: 2% of the bounding box diagonal)", "0");
  args.AddOption("--samples-per-line", "N", "PCD only: vertices per line, >= 2", "16");
  args.AddSwitch("--cameras", "add the camera centres");
  args.AddPositional("MAP", "map file (.lcmap or .json)");
  args.AddPositional("OUT", "output point cloud (.ply or .pcd)");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"OUT"});  // before any work
  const std::string in = args.Positional("MAP");
  const std::string out = args.Positional("OUT");
  if (!mapping::PointCloudFormatForPath(out)) {
    throw UsageError("OUT '" + out + "' must end in .ply or .pcd");
  }
  mapping::PointCloudExportOptions options;
  options.ascii = args.Has("--ascii");
  options.line_length = args.GetDouble("--line-length");
  options.samples_per_line = args.GetInt("--samples-per-line");
  options.include_cameras = args.Has("--cameras");
  if (options.line_length < 0) throw UsageError("--line-length must be >= 0");
  if (options.samples_per_line < 2 || options.samples_per_line > 10000) {
    throw UsageError("--samples-per-line must be in [2, 10000]");
  }
  std::cerr << "map export: reading " << in << "\n";
  const slam::Map map = mapping::ReadMap(in);
  const auto summary = mapping::ExportPointCloud(map, out, options);
  std::printf("exported %s: %zu points, %zu lines (segments of %.4g)%s\n", in.c_str(),
              map.points.size(), map.lines.size(), summary.line_length,
              options.include_cameras ? ", camera centres" : "");
  std::printf("wrote %s: %zu vertices, %zu edges\n", out.c_str(), summary.vertices, summary.edges);
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------

int RunMapTransform(int argc, char** argv) {
  ArgParser args(
      "lcv map transform IN OUT --sim3-align-to GT_TRAJECTORY [--max-time-diff S]\n"
      "                         [--ground-truth-poses]",
      "Moves a map into a ground truth's world frame: the Sim(3) (Umeyama, scale included)\n"
      "that maps the keyframes' camera centres onto the ground-truth centres at the same\n"
      "timestamps (nearest within --max-time-diff) is applied to every pose, point, covariance,\n"
      "line and restored point (privacy/map_alignment.h). For benchmarks and audits with ground\n"
      "truth (`lcv localize` errors, concealed regions of a scene.json); align a point map\n"
      "before converting it to lines (the anchor rule is not kept by the transform).\n"
      "With --ground-truth-poses, the paper's prebuilt map (Sec. 4.1): after the alignment the\n"
      "keyframes are put on their ground-truth poses and the points refined by a BA with those\n"
      "poses fixed; outlier observations and points left with fewer than two are removed\n"
      "(privacy/map_ground_truth_poses.h).",
      "lcv map transform slam_map.lcmap slam_map_gt.lcmap --sim3-align-to scene/map/groundtruth.txt");
  args.AddOption("--sim3-align-to", "FILE", "ground-truth trajectory (TUM or KITTI with times)");
  args.AddOption("--max-time-diff", "S", "timestamp tolerance of the association, seconds", "0.02");
  args.AddSwitch("--ground-truth-poses",
                 "then replace the keyframe poses by the ground truth and refine the points by "
                 "BA on them (point maps only)");
  args.AddSwitch("--camera-rotation-from-map",
                 "with --ground-truth-poses: turn the ground-truth orientations by the camera's "
                 "mean rotation against them (a ground truth of another body frame)");
  args.AddSwitch("--refine-poses",
                 "with --ground-truth-poses: then a BA of poses and points (the first two "
                 "keyframes held)");
  args.AddPositional("IN", "map to transform (.lcmap or .json)");
  args.AddPositional("OUT", "transformed map (.lcmap or .json)");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"OUT"});  // before any work
  const std::string in = args.Positional("IN");
  const std::string out = args.Positional("OUT");
  CheckMapOutputPath(out);
  const std::string gt_path = args.Get("--sim3-align-to");
  const double max_time_diff = args.GetDouble("--max-time-diff");
  if (!(max_time_diff >= 0)) throw UsageError("--max-time-diff must be >= 0");
  const mapping::Trajectory gt =
      mapping::ReadTrajectory(gt_path, mapping::DetectTrajectoryFormat(gt_path));
  std::cerr << "map transform: reading " << in << "\n";
  slam::Map map = mapping::ReadMap(in);
  std::string problem;
  const auto alignment = privacy::AlignMapToGroundTruth(map, gt, max_time_diff, &problem);
  if (!alignment) throw InputError(in, "cannot align to " + gt_path + ": " + problem);
  slam::Map aligned = privacy::TransformMap(map, alignment->gt_from_map);
  aligned.description = (map.description.empty() ? "" : map.description + " | ") +
                        "lcv map transform --sim3-align-to " + gt_path;
  privacy::GroundTruthPosesReport refined;
  const bool on_ground_truth = args.Has("--ground-truth-poses");
  if (on_ground_truth) {
    privacy::GroundTruthPosesOptions options;
    options.max_time_difference = max_time_diff;
    options.estimate_camera_rotation = args.Has("--camera-rotation-from-map");
    options.refine_poses = args.Has("--refine-poses");
    aligned = privacy::PutMapOnGroundTruthPoses(aligned, gt, options, in, &refined);
    aligned.description += " --ground-truth-poses";
    if (options.estimate_camera_rotation) aligned.description += " --camera-rotation-from-map";
    if (options.refine_poses) aligned.description += " --refine-poses";
  }
  mapping::ValidateMap(aligned, out);
  mapping::WriteMap(aligned, out);
  const slam::Sim3d& S = alignment->gt_from_map;
  std::printf("aligned %s to %s: %d keyframes matched, RMSE %.4f, scale %.6g\n", in.c_str(),
              gt_path.c_str(), alignment->matched, alignment->rmse, S.scale);
  if (on_ground_truth) {
    std::printf("ground-truth poses: %d keyframes (%d kept aligned), points %d -> %d "
                "(%d observations removed), reprojection RMS %.2f -> %.2f px, camera rotation "
                "against the ground truth %.3f deg, keyframes moved by up to %.3f\n",
                refined.keyframes_on_ground_truth, refined.keyframes_kept, refined.points_in,
                refined.points_out, refined.observations_removed, refined.rms_px_before,
                refined.rms_px_after, refined.camera_rotation_offset_deg,
                refined.max_pose_correction_m);
  }
  std::printf("wrote %s (%s)\n", out.c_str(), EncodingName(mapping::EncodingForPath(out)));
  return kExitOk;
}

// ---------------------------------------------------------------------------------------------

json StatisticsJson(const mapping::ErrorStatistics& s) {
  return {{"count", s.count}, {"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"max", s.max}};
}

std::string StatisticsText(const mapping::ErrorStatistics& s, const char* unit) {
  char text[160];
  std::snprintf(text, sizeof(text), "rmse %.4g %s, median %.4g, max %.4g", s.rmse, unit, s.median,
                s.max);
  return text;
}

int RunMapCompare(int argc, char** argv) {
  ArgParser args(
      "lcv map compare REFERENCE MAP [--align] [--report FILE.json]",
      "Compares a map with a reference map of the same scene, entity by entity, matched by id\n"
      "(COLMAP's model_comparer for lcv maps; mapping/map_compare.h): keyframes and server\n"
      "keyframes (centre distance, rotation angle), points and lines (point to point, point to\n"
      "line, line to line distance and angle), and the map's restored points X' against the\n"
      "reference's point of the same id. Ids survive conversion, merging and optimization, so\n"
      "this shows how far `lcv map optimize`, a merge or a client's global BA moved a line cloud,\n"
      "or how far a published line passes from the point it hides. --align first moves the map\n"
      "onto the reference by their common keyframes (a similarity: another frame or scale).",
      "lcv map compare lines.lcmap optimized.lcmap --report moved.json");
  args.AddPositional("REFERENCE", "the reference map (.lcmap or .json)");
  args.AddPositional("MAP", "the map compared with it");
  args.AddSwitch("--align", "move MAP onto REFERENCE by the similarity of their common keyframes");
  args.AddOption("--report", "FILE.json",
                 "write the summary and every entity's difference (id, kinds, distance, angle)");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"--report"});
  const std::string reference_path = args.Positional("REFERENCE");
  const std::string map_path = args.Positional("MAP");
  const slam::Map reference = mapping::ReadMap(reference_path);
  const slam::Map map = mapping::ReadMap(map_path);
  mapping::MapCompareOptions options;
  options.align = args.Has("--align");
  const mapping::MapComparison c = mapping::CompareMaps(reference, map, options);
  if (c.problem) {
    std::cerr << "lcv map compare: error: " << map_path << " vs " << reference_path << ": "
              << *c.problem << "\n";
    return kExitFailure;
  }

  std::printf("%s against %s", map_path.c_str(), reference_path.c_str());
  if (c.aligned) {
    std::printf(" (aligned by %zu keyframes: scale %.6f)", c.poses.size(), c.reference_from_map.scale);
  }
  std::printf("\nkeyframes: %zu in common, %d only in the reference, %d only in the map\n",
              c.poses.size(), c.poses_only_in_reference, c.poses_only_in_map);
  if (!c.poses.empty()) {
    std::printf("  centre %s\n  rotation %s\n", StatisticsText(c.pose_position_m, "m").c_str(),
                StatisticsText(c.pose_rotation_deg, "deg").c_str());
  }
  std::printf("points and lines: %zu in common, %d only in the reference, %d only in the map\n",
              c.structure.size(), c.structure_only_in_reference, c.structure_only_in_map);
  for (int k = 0; k < 4; ++k) {
    const mapping::ErrorStatistics& s = c.structure_distance_m[k];
    if (s.count == 0) continue;
    std::printf("  %s %d: distance %s", mapping::StructurePairName(static_cast<mapping::StructurePair>(k)),
                s.count, StatisticsText(s, "m").c_str());
    if (k == static_cast<int>(mapping::StructurePair::kLineLine)) {
      std::printf("; angle %s", StatisticsText(c.line_angle_deg, "deg").c_str());
    }
    std::printf("\n");
  }
  if (c.restored_distance_m.count > 0) {
    std::printf("restored points X' %d: distance to the reference's point %s\n",
                c.restored_distance_m.count, StatisticsText(c.restored_distance_m, "m").c_str());
  }

  if (const auto report_path = args.GetOptional("--report")) {
    json report{{"reference", reference_path},
                {"map", map_path},
                {"aligned", c.aligned},
                {"scale", c.reference_from_map.scale},
                {"keyframes", {{"common", c.poses.size()},
                               {"only_in_reference", c.poses_only_in_reference},
                               {"only_in_map", c.poses_only_in_map},
                               {"centre_m", StatisticsJson(c.pose_position_m)},
                               {"rotation_deg", StatisticsJson(c.pose_rotation_deg)}}},
                {"structure", {{"common", c.structure.size()},
                               {"only_in_reference", c.structure_only_in_reference},
                               {"only_in_map", c.structure_only_in_map},
                               {"line_angle_deg", StatisticsJson(c.line_angle_deg)}}},
                {"restored_points_m", StatisticsJson(c.restored_distance_m)}};
    for (int k = 0; k < 4; ++k) {
      report["structure"][mapping::StructurePairName(static_cast<mapping::StructurePair>(k))] =
          StatisticsJson(c.structure_distance_m[k]);
    }
    json poses = json::array(), structure = json::array(), restored = json::array();
    for (const mapping::PoseDifference& d : c.poses) {
      poses.push_back({{"id", d.id},
                       {"reference", d.server_in_reference ? "server" : "client"},
                       {"map", d.server_in_map ? "server" : "client"},
                       {"centre_m", d.position_m},
                       {"rotation_deg", d.rotation_deg}});
    }
    for (const mapping::StructureDifference& d : c.structure) {
      json entry{{"id", d.id}, {"pair", mapping::StructurePairName(d.pair)}, {"distance_m", d.distance_m}};
      if (d.pair == mapping::StructurePair::kLineLine) entry["angle_deg"] = d.angle_deg;
      structure.push_back(entry);
    }
    for (const mapping::RestoredDifference& d : c.restored) {
      restored.push_back({{"id", d.id}, {"distance_m", d.distance_m}});
    }
    report["per_keyframe"] = poses;
    report["per_point_or_line"] = structure;
    report["per_restored_point"] = restored;
    mapping::WriteFileAtomically(*report_path, report.dump(1) + "\n");
    std::printf("wrote %s\n", report_path->c_str());
  }
  return kExitOk;
}

}  // namespace

LCV_REGISTER_COMMAND("map import", "COLMAP text model -> point map", RunMapImport);
LCV_REGISTER_COMMAND("map convert", "point map -> published line cloud", RunMapConvert);
LCV_REGISTER_COMMAND("map info", "counts, bounds, schema of a map file", RunMapInfo);
LCV_REGISTER_COMMAND("map export", "map -> PLY / PCD point cloud", RunMapExport);
LCV_REGISTER_COMMAND("map transform", "map -> ground-truth frame (Sim(3) keyframe alignment)",
                     RunMapTransform);
LCV_REGISTER_COMMAND("map compare", "how far each keyframe, point and line moved against a reference",
                     RunMapCompare);

}  // namespace lcv::apps
