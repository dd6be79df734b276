// `lcv eval ape|rpe`: absolute / relative pose error of an estimated trajectory against ground
// truth, as evo computes them (mapping/eval/trajectory_error.h).
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/eval/trajectory_error.h"
#include "mapping/eval/trajectory_plot.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/camera_file.h"
#include "mapping/io/trajectory.h"
#include "render/map_snapshot.h"
#include "slam/solve/umeyama.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using mapping::Trajectory;
using mapping::TrajectoryFormat;

TrajectoryFormat FormatOption(const ArgParser& args, const std::string& flag,
                              const std::string& path) {
  const std::string name = args.Get(flag);
  if (name == "auto") return mapping::DetectTrajectoryFormat(path);
  const auto format = mapping::ParseTrajectoryFormat(name);
  if (!format) throw UsageError(flag + ": '" + name + "' is not one of auto, tum, kitti");
  return *format;
}

std::string Fixed(double value, int decimals = 6) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals, value);
  return buffer;
}

void StatsJson(const mapping::ErrorStatistics& s, const std::string& prefix,
               const std::string& suffix, nlohmann::json* out) {
  (*out)[prefix + "rmse" + suffix] = s.rmse;
  (*out)[prefix + "mean" + suffix] = s.mean;
  (*out)[prefix + "median" + suffix] = s.median;
  (*out)[prefix + "std" + suffix] = s.std;
  (*out)[prefix + "min" + suffix] = s.min;
  (*out)[prefix + "max" + suffix] = s.max;
  (*out)[prefix + "sse" + suffix] = s.sse;
}

void WriteErrorsCsv(const mapping::TrajectoryErrorReport& report, const std::string& path) {
  std::string csv = "index,timestamp,translation_error_m,rotation_error_deg\n";
  for (size_t k = 0; k < report.timestamps.size(); ++k) {
    csv += std::to_string(k) + "," + mapping::FormatDoubleExact(report.timestamps[k]) + "," +
           mapping::FormatDoubleExact(report.translation_errors[k]) + "," +
           mapping::FormatDoubleExact(report.rotation_errors_deg[k]) + "\n";
  }
  mapping::WriteFileAtomically(path, csv);
}

// The estimate over the ground truth, coloured by its error (evo_ape --plot), as a PNG.
void WritePlot(const mapping::TrajectoryErrorReport& report, const Trajectory& gt,
               const std::string& title, const std::string& error_label,
               const mapping::TrajectoryPlotOptions& base, const std::string& path) {
  mapping::TrajectoryPlotData data;
  for (const mapping::StampedPose& pose : gt.poses) {
    data.reference_path.push_back(pose.cam_from_world.Center());
  }
  data.gt_centres = report.gt_centres;
  data.est_centres = report.est_centres;
  data.errors = report.translation_errors;
  mapping::TrajectoryPlotOptions options = base;
  options.title = title;
  options.error_label = error_label;
  const cv::Mat image = mapping::PlotTrajectoryErrors(data, options);
  render::WritePng(image, path);
}

int RunEval(int argc, char** argv, bool relative) {
  const std::string metric = relative ? "rpe" : "ape";
  ArgParser args(
      "lcv eval " + metric + " --gt FILE --est FILE [options]",
      relative
          ? "Relative pose error (evo_rpe): for pose pairs (i, i + delta) of the associated poses,\n"
            "E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j); translation error |trans(E)| (gt units), rotation\n"
            "error angle(E) in degrees. Pairs (0,d), (d,2d), ... unless --all-pairs."
          : "Absolute pose error (evo_ape): after associating poses by timestamp and aligning the\n"
            "estimate (Umeyama), E_i = Q_i^-1 P_i; translation error |trans(E_i)| (gt units, metres\n"
            "for metric ground truth), rotation error angle(E_i) in degrees.",
      "lcv eval " + metric + " --gt poses.txt --est slam_tum.txt --times times.txt --align sim3 --json");
  args.AddOption("--gt", "FILE", "ground-truth trajectory (camera-to-world, TUM or KITTI)");
  args.AddOption("--est", "FILE", "estimated trajectory (camera-to-world, TUM or KITTI)");
  args.AddOption("--align", "MODE",
                 "alignment of the estimate onto the ground truth: none, se3 (rigid), sim3 "
                 "(rigid + scale, for monocular)",
                 "none");
  args.AddSwitch("--align-orientations",
                 "with --align se3|sim3: take the alignment's rotation from the cameras' "
                 "orientations, scale and translation from the centres (not evo's: evo fits the "
                 "centres alone, which leaves the rotation about a nearly straight path to noise); the "
                 "ground truth must be of the same camera frame, not of a body or IMU frame");
  args.AddOption("--gt-format", "FMT", "format of --gt: auto (from the column count), tum, kitti",
                 "auto");
  args.AddOption("--est-format", "FMT", "format of --est: auto, tum, kitti", "auto");
  args.AddOption("--times", "FILE",
                 "timestamps (one per line) for the KITTI-format file(s), which have none; "
                 "without it their line index is the timestamp");
  args.AddOption("--t-max-diff", "SEC", "largest timestamp difference of associated poses", "0.01");
  if (relative) {
    args.AddOption("--delta", "N", "pose pairs N associated poses apart", "1");
    args.AddSwitch("--all-pairs", "use every pair (i, i + N), not only (0, N), (N, 2N), ...");
  }
  args.AddOption("--errors-out", "FILE.csv",
                 "write the per-pose (per-pair) errors: index,timestamp,translation_error_m,"
                 "rotation_error_deg");
  args.AddOption("--plot", "FILE.png",
                 std::string("draw the estimate (aligned) over the ground truth seen from above, "
                             "coloured by its translation error") +
                     (relative ? " (a pair's error at its first pose)" : "") +
                     ", with the grid in metres (evo's --plot)");
  args.AddOption("--plot-axes", "AXES",
                 "world axes of the plot, to the right and up: xy, xz, yz, ... or auto (the two "
                 "along which the trajectories spread most)",
                 "auto");
  args.AddOption("--plot-size", "WxH", "plot image size (320 <= W, H <= 8192)", "1000x800");
  args.AddOption("--max-rmse", "M", "exit with code 3 when the translation RMSE exceeds M");
  args.AddSwitch("--json",
                 "print one JSON object (rmse, mean, median, std, min, max, sse, rot_*_deg, "
                 "matched, scale, ...) instead of the summary");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"--errors-out", "--plot"});  // before any work
  mapping::TrajectoryPlotOptions plot_options;
  std::tie(plot_options.width, plot_options.height) = args.GetSize("--plot-size", 320, 8192);
  if (args.Get("--plot-axes") != "auto") {
    plot_options.axes = mapping::ParsePlotAxes(args.Get("--plot-axes"));
    if (!plot_options.axes) {
      throw UsageError("--plot-axes: '" + args.Get("--plot-axes") +
                       "' is not auto or two different letters of x, y, z (xy, xz, zy, ...)");
    }
  }

  const std::string gt_path = args.Get("--gt");
  const std::string est_path = args.Get("--est");
  const auto alignment = mapping::ParseTrajectoryAlignment(args.Get("--align"));
  if (!alignment) throw UsageError("--align: '" + args.Get("--align") + "' is not one of none, se3, sim3");
  mapping::TrajectoryErrorOptions options;
  options.alignment = *alignment;
  options.align_with_orientations = args.Has("--align-orientations");
  if (options.align_with_orientations && options.alignment == mapping::TrajectoryAlignment::kNone) {
    throw UsageError("--align-orientations needs --align se3 or sim3");
  }
  options.max_time_difference_s = args.GetDouble("--t-max-diff");
  if (options.max_time_difference_s < 0) throw UsageError("--t-max-diff must be >= 0");
  if (relative) {
    options.rpe_delta = args.GetInt("--delta");
    if (options.rpe_delta < 1) throw UsageError("--delta must be >= 1");
    options.rpe_all_pairs = args.Has("--all-pairs");
  }
  const std::optional<std::string> max_rmse_text = args.GetOptional("--max-rmse");
  const double max_rmse = max_rmse_text ? args.GetDouble("--max-rmse") : 0.0;

  Trajectory gt = mapping::ReadTrajectory(gt_path, FormatOption(args, "--gt-format", gt_path));
  Trajectory est = mapping::ReadTrajectory(est_path, FormatOption(args, "--est-format", est_path));
  if (const auto times_path = args.GetOptional("--times")) {
    const std::vector<double> times = mapping::ReadTimesFile(*times_path);
    bool used = false;
    for (Trajectory* t : {&gt, &est}) {
      if (!t->has_timestamps) {
        mapping::AssignTimestamps(times, *times_path, t);
        used = true;
      }
    }
    if (!used) throw UsageError("--times given but neither trajectory is in KITTI format");
  }

  // Line indices and real timestamps cannot be associated: refuse instead of matching nonsense.
  if (gt.has_timestamps != est.has_timestamps) {
    throw UsageError(std::string(gt.has_timestamps ? "--est" : "--gt") +
                     " is a KITTI file (no timestamps) and the other has timestamps: pass "
                     "--times FILE with the KITTI file's timestamps");
  }
  if (!gt.has_timestamps && gt.poses.size() != est.poses.size()) {
    std::cerr << "lcv eval " << metric << ": note: KITTI files of different lengths ("
              << gt.poses.size() << " and " << est.poses.size()
              << " poses) are associated by line index\n";
  }
  const mapping::TrajectoryErrorReport report =
      relative ? mapping::ComputeRpe(gt, est, options) : mapping::ComputeApe(gt, est, options);
  if (report.problem) {
    std::cerr << "lcv eval " << metric << ": error: " << est_path << " vs " << gt_path << ": "
              << *report.problem << "\n";
    return kExitFailure;
  }
  // evo's centres-only fit on a nearly straight path: say that its rotation is a guess (APE
  // only: a relative error does not change with the alignment's rotation).
  if (!relative && options.alignment != mapping::TrajectoryAlignment::kNone &&
      !options.align_with_orientations && report.centre_spread_ratio < slam::kMinDatumSpreadRatio) {
    std::cerr << "lcv eval " << metric << ": note: the ground-truth centres lie nearly on a line "
              << "(second spread " << Fixed(report.centre_spread_ratio, 4)
              << " of the first): the alignment's rotation about it is poorly determined by the "
                 "centres, and the rotation errors carry it; --align-orientations takes the "
                 "rotation from the cameras' orientations\n";
  }
  if (const auto errors_path = args.GetOptional("--errors-out")) {
    WriteErrorsCsv(report, *errors_path);
  }
  if (const auto plot_path = args.GetOptional("--plot")) {
    const std::string title =
        std::string(relative ? "RPE" : "APE") + " of " +
        std::filesystem::path(est_path).filename().string() + ", alignment " +
        mapping::TrajectoryAlignmentName(options.alignment) + ": rmse " +
        Fixed(report.translation.rmse, 3) + " m, " + std::to_string(report.translation.count) +
        (relative ? " pairs" : " poses");
    WritePlot(report, gt, title, relative ? "RPE m" : "APE m", plot_options, *plot_path);
  }

  if (args.Has("--json")) {
    nlohmann::json out;
    out["metric"] = metric;
    out["gt"] = gt_path;
    out["est"] = est_path;
    out["align"] = mapping::TrajectoryAlignmentName(options.alignment);
    out["align_orientations"] = options.align_with_orientations;
    out["centre_spread_ratio"] = report.centre_spread_ratio;
    out["matched"] = report.matched;
    out["count"] = report.translation.count;
    if (relative) {
      out["delta"] = options.rpe_delta;
      out["all_pairs"] = options.rpe_all_pairs;
    }
    StatsJson(report.translation, "", "", &out);
    StatsJson(report.rotation_deg, "rot_", "_deg", &out);
    out["scale"] = report.gt_from_est.scale;
    const Eigen::Quaterniond& q = report.gt_from_est.rotation;
    const Eigen::Vector3d& t = report.gt_from_est.translation;
    out["gt_from_est"] = {{"scale", report.gt_from_est.scale},
                          {"rotation_xyzw", {q.x(), q.y(), q.z(), q.w()}},
                          {"translation", {t.x(), t.y(), t.z()}}};
    std::cout << out.dump() << "\n";
  } else {
    const auto& s = report.translation;
    const auto& r = report.rotation_deg;
    std::cout << (relative ? "RPE" : "APE") << " of " << est_path << " vs " << gt_path << "\n"
              << "  matched " << report.matched << " poses"
              << (relative ? ", " + std::to_string(s.count) + " pairs (delta " +
                                 std::to_string(options.rpe_delta) + ")"
                           : std::string())
              << ", alignment " << mapping::TrajectoryAlignmentName(options.alignment);
    if (options.alignment == mapping::TrajectoryAlignment::kSim3) {
      std::cout << " (scale " << Fixed(report.gt_from_est.scale, 6) << ")";
    }
    if (options.align_with_orientations) std::cout << ", rotation from the orientations";
    std::cout << "\n"
              << "  translation (m):  rmse " << Fixed(s.rmse) << "  mean " << Fixed(s.mean)
              << "  median " << Fixed(s.median) << "  std " << Fixed(s.std) << "  min "
              << Fixed(s.min) << "  max " << Fixed(s.max) << "\n"
              << "  rotation (deg):   rmse " << Fixed(r.rmse, 4) << "  mean " << Fixed(r.mean, 4)
              << "  median " << Fixed(r.median, 4) << "  max " << Fixed(r.max, 4) << "\n";
  }
  if (max_rmse_text && report.translation.rmse > max_rmse) {
    std::cerr << "lcv eval " << metric << ": translation rmse " << report.translation.rmse
              << " exceeds --max-rmse " << max_rmse << "\n";
    return kExitCheckFailed;
  }
  return kExitOk;
}

int RunEvalApe(int argc, char** argv) { return RunEval(argc, argv, /*relative=*/false); }
int RunEvalRpe(int argc, char** argv) { return RunEval(argc, argv, /*relative=*/true); }

}  // namespace
LCV_REGISTER_COMMAND("eval ape", "absolute pose error of a trajectory (evo_ape)", RunEvalApe);
LCV_REGISTER_COMMAND("eval rpe", "relative pose error of a trajectory (evo_rpe)", RunEvalRpe);
}  // namespace lcv::apps
