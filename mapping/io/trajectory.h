#pragma once
// Camera trajectories in the two text formats every evaluation tool reads (evo, TUM and KITTI
// scripts).
//
// TUM:   one pose per line, `timestamp tx ty tz qx qy qz qw` (seconds, metres, Hamilton
//        quaternion with w last); lines starting with '#' and blank lines are skipped.
// KITTI: one pose per line, 12 numbers, the row-major 3x4 matrix [R | t]; no timestamps (the
//        line index, or a separate times file with one timestamp per line).
// Both store camera-to-world (world_from_cam: t is the camera centre). In memory we keep the
// project's convention, cam_from_world (slam/geometry/rigid3.h); readers and writers invert.
//
// Readers validate everything and throw lcv::InputError naming the file, the line and the
// problem ("est.txt: line 17: expected 8 numbers (timestamp tx ty tz qx qy qz qw), got 7").
// Timestamps must be finite and strictly increasing.

#include <optional>
#include <string>
#include <vector>

#include "slam/geometry/rigid3.h"

namespace lcv::mapping {

enum class TrajectoryFormat { kTum, kKitti };

// "tum" / "kitti"; empty for anything else.
std::optional<TrajectoryFormat> ParseTrajectoryFormat(const std::string& name);
const char* TrajectoryFormatName(TrajectoryFormat format);

struct StampedPose {
  double timestamp = 0.0;  // seconds (KITTI without times file: the line index)
  slam::Rigid3d cam_from_world;
};

struct Trajectory {
  std::vector<StampedPose> poses;  // in file order, timestamps strictly increasing
  // False for a KITTI file read without times: the timestamps are line indices 0, 1, 2, ...
  bool has_timestamps = true;
};

// A trajectory from any sequence of records with `timestamp` and `cam_from_world` members, in
// order (e.g. slam::System::FrameTrajectory()).
template <typename Poses>
Trajectory MakeTrajectory(const Poses& poses) {
  Trajectory trajectory;
  trajectory.poses.reserve(poses.size());
  for (const auto& p : poses) trajectory.poses.push_back({p.timestamp, p.cam_from_world});
  return trajectory;
}

// Reads a TUM or KITTI file. Throws lcv::InputError.
Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format);
// Format from the content: 8 columns on the first data line -> TUM, 12 -> KITTI. Throws
// lcv::InputError when neither (or the file is empty or unreadable).
TrajectoryFormat DetectTrajectoryFormat(const std::string& path);

// One timestamp (seconds) per line, as KITTI's times.txt and the synthetic sets' times.txt.
// Strictly increasing. Throws lcv::InputError.
std::vector<double> ReadTimesFile(const std::string& path);
// Replaces the index timestamps of a KITTI trajectory with times[i]. Throws lcv::InputError
// naming times_source when the counts differ.
void AssignTimestamps(const std::vector<double>& times, const std::string& times_source,
                      Trajectory* trajectory);

// Writers: atomic (temporary file + rename), every number printed in its shortest exact form,
// so a write/read round trip loses only the rounding of the world_from_cam inversion and of
// the KITTI matrix -> quaternion conversion (~1e-15 relative). Throw lcv::InputError on I/O
// failure.
void WriteTrajectory(const Trajectory& trajectory, const std::string& path,
                     TrajectoryFormat format);
std::string SerializeTrajectory(const Trajectory& trajectory, TrajectoryFormat format);

}  // namespace lcv::mapping
