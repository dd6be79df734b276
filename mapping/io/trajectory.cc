#include "mapping/io/trajectory.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "mapping/io/atomic_file.h"
#include "mapping/io/camera_file.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

// A data line of a text file: its 1-based number and its numbers.
struct NumberLine {
  int number = 0;
  std::vector<double> values;
};

// Splits on blanks (and commas, which some tools write); skips blank lines and '#' comments.
std::vector<NumberLine> ReadNumberLines(const std::string& bytes, const std::string& path) {
  std::vector<NumberLine> lines;
  std::istringstream in(bytes);
  std::string text;
  int number = 0;
  while (std::getline(in, text)) {
    ++number;
    for (char& c : text) {
      if (c == ',' || c == '\t' || c == '\r') c = ' ';
    }
    const size_t first = text.find_first_not_of(' ');
    if (first == std::string::npos || text[first] == '#') continue;
    NumberLine line{number, {}};
    std::istringstream tokens(text);
    std::string token;
    while (tokens >> token) {
      errno = 0;
      char* end = nullptr;
      const double v = std::strtod(token.c_str(), &end);
      if (*end != '\0' || errno == ERANGE || !std::isfinite(v)) {
        throw InputError(path, "line " + std::to_string(number) + ": '" + token +
                                   "' is not a finite number");
      }
      line.values.push_back(v);
    }
    lines.push_back(std::move(line));
  }
  return lines;
}

void CheckIncreasing(double previous, double current, const std::string& path, int line) {
  if (!(current > previous)) {
    throw InputError(path, "line " + std::to_string(line) + ": timestamp " +
                               FormatDoubleExact(current) +
                               " is not greater than the previous one (" +
                               FormatDoubleExact(previous) + ")");
  }
}

Trajectory ParseTum(const std::vector<NumberLine>& lines, const std::string& path) {
  Trajectory trajectory;
  trajectory.has_timestamps = true;
  for (const NumberLine& line : lines) {
    const std::string where = "line " + std::to_string(line.number) + ": ";
    if (line.values.size() != 8) {
      throw InputError(path, where + "expected 8 numbers (timestamp tx ty tz qx qy qz qw), got " +
                                 std::to_string(line.values.size()));
    }
    const auto& v = line.values;
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // w, x, y, z
    const double norm = q.norm();
    if (std::fabs(norm - 1.0) > 0.05) {
      throw InputError(path, where + "quaternion (qx qy qz qw) has norm " + FormatDoubleExact(norm) +
                                 ", expected 1");
    }
    q.normalize();
    if (!trajectory.poses.empty()) {
      CheckIncreasing(trajectory.poses.back().timestamp, v[0], path, line.number);
    }
    const slam::Rigid3d world_from_cam(q, Eigen::Vector3d(v[1], v[2], v[3]));
    trajectory.poses.push_back({v[0], world_from_cam.Inverse()});
  }
  return trajectory;
}

Trajectory ParseKitti(const std::vector<NumberLine>& lines, const std::string& path) {
  Trajectory trajectory;
  trajectory.has_timestamps = false;
  for (const NumberLine& line : lines) {
    const std::string where = "line " + std::to_string(line.number) + ": ";
    if (line.values.size() != 12) {
      throw InputError(path, where + "expected 12 numbers (row-major 3x4 [R|t]), got " +
                                 std::to_string(line.values.size()));
    }
    Eigen::Matrix<double, 3, 4> m;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) m(r, c) = line.values[4 * r + c];
    }
    const Eigen::Matrix3d R = m.leftCols<3>();
    const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
    if (orthogonality > 1e-2 || R.determinant() <= 0.0) {
      throw InputError(path, where + "the 3x3 part is not a rotation (|R^T R - I| = " +
                                 FormatDoubleExact(orthogonality) + ", det = " +
                                 FormatDoubleExact(R.determinant()) + ")");
    }
    const slam::Rigid3d world_from_cam = slam::Rigid3d::FromMatrix(m);
    const double index = static_cast<double>(trajectory.poses.size());
    trajectory.poses.push_back({index, world_from_cam.Inverse()});
  }
  return trajectory;
}

}  // namespace

std::optional<TrajectoryFormat> ParseTrajectoryFormat(const std::string& name) {
  if (name == "tum" || name == "TUM") return TrajectoryFormat::kTum;
  if (name == "kitti" || name == "KITTI") return TrajectoryFormat::kKitti;
  return std::nullopt;
}

const char* TrajectoryFormatName(TrajectoryFormat format) {
  return format == TrajectoryFormat::kTum ? "tum" : "kitti";
}

Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format) {
  const auto lines = ReadNumberLines(ReadTextFile(path), path);
  if (lines.empty()) throw InputError(path, "no poses");
  return format == TrajectoryFormat::kTum ? ParseTum(lines, path) : ParseKitti(lines, path);
}

TrajectoryFormat DetectTrajectoryFormat(const std::string& path) {
  const auto lines = ReadNumberLines(ReadTextFile(path), path);
  if (lines.empty()) throw InputError(path, "no poses");
  const size_t columns = lines.front().values.size();
  if (columns == 8) return TrajectoryFormat::kTum;
  if (columns == 12) return TrajectoryFormat::kKitti;
  throw InputError(path, "line " + std::to_string(lines.front().number) + ": " +
                             std::to_string(columns) +
                             " numbers: neither TUM (8: timestamp tx ty tz qx qy qz qw) nor "
                             "KITTI (12: row-major 3x4 [R|t])");
}

std::vector<double> ReadTimesFile(const std::string& path) {
  std::vector<double> times;
  for (const NumberLine& line : ReadNumberLines(ReadTextFile(path), path)) {
    if (line.values.size() != 1) {
      throw InputError(path, "line " + std::to_string(line.number) +
                                 ": expected one timestamp, got " +
                                 std::to_string(line.values.size()) + " numbers");
    }
    if (!times.empty()) CheckIncreasing(times.back(), line.values[0], path, line.number);
    times.push_back(line.values[0]);
  }
  if (times.empty()) throw InputError(path, "no timestamps");
  return times;
}

void AssignTimestamps(const std::vector<double>& times, const std::string& times_source,
                      Trajectory* trajectory) {
  if (times.size() != trajectory->poses.size()) {
    throw InputError(times_source, std::to_string(times.size()) + " timestamps for " +
                                       std::to_string(trajectory->poses.size()) + " poses");
  }
  for (size_t i = 0; i < times.size(); ++i) trajectory->poses[i].timestamp = times[i];
  trajectory->has_timestamps = true;
}

std::string SerializeTrajectory(const Trajectory& trajectory, TrajectoryFormat format) {
  std::string out;
  out.reserve(trajectory.poses.size() * 120);
  for (const StampedPose& pose : trajectory.poses) {
    const slam::Rigid3d world_from_cam = pose.cam_from_world.Inverse();
    if (format == TrajectoryFormat::kTum) {
      const Eigen::Vector3d& t = world_from_cam.translation;
      const Eigen::Quaterniond& q = world_from_cam.rotation;
      for (const double v : {pose.timestamp, t.x(), t.y(), t.z(), q.x(), q.y(), q.z()}) {
        out += FormatDoubleExact(v);
        out += ' ';
      }
      out += FormatDoubleExact(q.w());
    } else {
      const Eigen::Matrix<double, 3, 4> m = world_from_cam.ToMatrix();
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) {
          out += FormatDoubleExact(m(r, c));
          if (r != 2 || c != 3) out += ' ';
        }
      }
    }
    out += '\n';
  }
  return out;
}

void WriteTrajectory(const Trajectory& trajectory, const std::string& path,
                     TrajectoryFormat format) {
  WriteFileAtomically(path, SerializeTrajectory(trajectory, format));
}

}  // namespace lcv::mapping
