// Semantic checks of a map (the invariants listed in slam/data/map.h), shared by the file
// reader and the importers. Every message names the entity by its JSON pointer in the file.
#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

#include "mapping/io/map_file.h"
#include "mapping/io/map_internal.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace internal {
namespace {

using slam::Id;

// Tolerances: files written by WriteMap round-trip exactly, so these only absorb the rounding of
// whoever computed the values.
constexpr double kUnitNormTolerance = 1e-6;
constexpr double kSymmetryTolerance = 1e-8;   // relative to the largest entry
constexpr double kPsdTolerance = 1e-9;        // smallest eigenvalue >= -tol * largest |eigenvalue|
constexpr double kNullSpaceTolerance = 1e-6;  // |Omega d| <= tol * |Omega|

// Plausible ranges (docs/map-format.md). Finite values beyond them are corrupt or hostile: they
// overflow later arithmetic (squares of 1e154 are infinite; a keyframe at -1e308 gave points
// with infinite covariances) although every single number is finite.
constexpr double kMaxCoordinate = 1e9;       // |position|, |anchor|, |translation|, map units
constexpr double kMaxMatrixEntry = 1e30;     // |covariance|, |information| entries

class Checker {
 public:
  explicit Checker(const std::string& source) : source_(source) {}

  // "/lines/17" for the entity with this id.
  std::string Where(const char* container, const std::map<Id, std::size_t>& table, Id id,
                    std::size_t ordinal) const {
    const auto it = table.find(id);
    std::ostringstream out;
    out << "/" << container << "/" << (it != table.end() ? it->second : ordinal);
    return out.str();
  }

  [[noreturn]] void Fail(const std::string& pointer, const std::string& what) const {
    throw InputError(source_, pointer + ": " + what);
  }

  void CheckFinite(const std::string& pointer, const double* values, int count) const {
    for (int i = 0; i < count; ++i) {
      if (!std::isfinite(values[i])) Fail(pointer, "not a finite number");
    }
  }

  // Finite and |value| <= bound, each value named by its index ("/points/3/position/1").
  void CheckBounded(const std::string& pointer, const double* values, int count,
                    double bound) const {
    for (int i = 0; i < count; ++i) {
      const std::string at = pointer + "/" + std::to_string(i);
      if (!std::isfinite(values[i])) Fail(at, "not a finite number");
      if (std::abs(values[i]) > bound) {
        std::ostringstream out;
        out << values[i] << " is outside the plausible range [-" << bound << ", " << bound
            << "] (docs/map-format.md)";
        Fail(at, out.str());
      }
    }
  }

  void CheckUnit(const std::string& pointer, double norm) const {
    if (!(std::abs(norm - 1.0) <= kUnitNormTolerance)) {
      std::ostringstream out;
      out << "norm " << norm << ", expected 1";
      Fail(pointer, out.str());
    }
  }

  void CheckPose(const std::string& pointer, const slam::Rigid3d& pose) const {
    CheckFinite(pointer + "/rotation_wxyz", pose.rotation.coeffs().data(), 4);
    CheckBounded(pointer + "/translation", pose.translation.data(), 3, kMaxCoordinate);
    CheckUnit(pointer + "/rotation_wxyz", pose.rotation.norm());
  }

  // Symmetric positive semi-definite.
  void CheckSymmetricPsd(const std::string& pointer, const Eigen::Matrix3d& m) const {
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> row_major = m;  // file order
    CheckBounded(pointer, row_major.data(), 9, kMaxMatrixEntry);
    const double scale = m.cwiseAbs().maxCoeff();
    if ((m - m.transpose()).cwiseAbs().maxCoeff() > kSymmetryTolerance * scale) {
      Fail(pointer, "not symmetric");
    }
    const Eigen::Vector3d eigenvalues =
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m, Eigen::EigenvaluesOnly).eigenvalues();
    if (eigenvalues.minCoeff() < -kPsdTolerance * eigenvalues.cwiseAbs().maxCoeff()) {
      std::ostringstream out;
      out << "not positive semi-definite (eigenvalue " << eigenvalues.minCoeff() << ")";
      Fail(pointer, out.str());
    }
  }

 private:
  const std::string& source_;
};

}  // namespace

void ValidateMapAt(const slam::Map& map, const std::string& source, const EntityLocator& locator) {
  const Checker check(source);
  // Ids are unique map-wide (slam/data/map.h): a point converted to a line keeps its id.
  std::map<Id, std::string> owner;
  auto claim = [&](Id id, const std::string& pointer) {
    if (id == slam::kInvalidId) check.Fail(pointer + "/id", "the reserved invalid id");
    const auto [it, inserted] = owner.emplace(id, pointer);
    if (!inserted) {
      check.Fail(pointer + "/id", "id " + std::to_string(id) + " already used by " + it->second);
    }
  };

  std::size_t ordinal = 0;
  for (const auto& [id, camera] : map.cameras) {
    const std::string at = check.Where("cameras", locator.cameras, id, ordinal++);
    claim(id, at);
    if (const auto problem = camera.Problem()) check.Fail(at, *problem);
  }
  auto camera_exists = [&](const std::string& at, Id camera_id) {
    if (!map.cameras.count(camera_id)) {
      check.Fail(at + "/camera_id", "no camera with id " + std::to_string(camera_id));
    }
  };
  ordinal = 0;
  for (const auto& [id, kf] : map.keyframes) {
    const std::string at = check.Where("keyframes", locator.keyframes, id, ordinal++);
    claim(id, at);
    camera_exists(at, kf.camera_id);
    if (!std::isfinite(kf.timestamp)) check.Fail(at + "/timestamp", "not a finite number");
    check.CheckPose(at + "/cam_from_world", kf.cam_from_world);
    if (!kf.descriptors.empty() && kf.descriptors.size() != kf.keypoints.size()) {
      check.Fail(at + "/descriptors", std::to_string(kf.descriptors.size()) + " descriptors for " +
                                          std::to_string(kf.keypoints.size()) + " keypoints");
    }
    for (std::size_t i = 0; i < kf.keypoints.size(); ++i) {
      const slam::Keypoint& kp = kf.keypoints[i];
      const std::string kp_at = at + "/keypoints/" + std::to_string(i);
      if (!std::isfinite(kp.x) || !std::isfinite(kp.y)) check.Fail(kp_at, "not a finite pixel");
      // Keypoints lie in the image; one image size of margin on each side (never reached by
      // real detectors) keeps the check lenient.
      const slam::CameraParams& camera = map.cameras.at(kf.camera_id);
      if (kp.x < -camera.cols || kp.x > 2.0 * camera.cols || kp.y < -camera.rows ||
          kp.y > 2.0 * camera.rows) {
        std::ostringstream out;
        out << "pixel (" << kp.x << ", " << kp.y << ") is far outside the " << camera.cols << "x"
            << camera.rows << " image (allowed: [-cols, 2 cols] x [-rows, 2 rows])";
        check.Fail(kp_at, out.str());
      }
      if (!(kp.angle_deg == -1.f || (kp.angle_deg >= 0.f && kp.angle_deg < 360.f))) {
        check.Fail(kp_at + "/2", "angle must be in [0, 360) or -1");
      }
      if (kp.octave < 0 || kp.octave > 63) check.Fail(kp_at + "/3", "octave must be in [0, 63]");
    }
  }
  ordinal = 0;
  for (const auto& [id, kf] : map.server_keyframes) {
    claim(id, check.Where("server_keyframes", locator.server_keyframes, id, ordinal++));
  }
  ordinal = 0;
  for (const auto& [id, point] : map.points) {
    claim(id, check.Where("points", locator.points, id, ordinal++));
  }
  ordinal = 0;
  for (const auto& [id, line] : map.lines) {
    claim(id, check.Where("lines", locator.lines, id, ordinal++));
  }

  auto check_observations = [&](const std::string& at,
                                const std::vector<slam::Observation>& observations) {
    for (std::size_t i = 0; i < observations.size(); ++i) {
      const slam::Observation& obs = observations[i];
      const std::string obs_at = at + "/observations/" + std::to_string(i);
      const auto kf = map.keyframes.find(obs.keyframe_id);
      if (kf == map.keyframes.end()) {
        check.Fail(obs_at + "/0", "no keyframe with id " + std::to_string(obs.keyframe_id));
      }
      if (obs.keypoint_index >= kf->second.keypoints.size()) {
        check.Fail(obs_at + "/1", "keypoint index " + std::to_string(obs.keypoint_index) +
                                      " out of range (keyframe " + std::to_string(obs.keyframe_id) +
                                      " has " + std::to_string(kf->second.keypoints.size()) + ")");
      }
    }
  };

  ordinal = 0;
  for (const auto& [id, kf] : map.server_keyframes) {
    const std::string at = check.Where("server_keyframes", locator.server_keyframes, id, ordinal++);
    camera_exists(at, kf.camera_id);
    if (!std::isfinite(kf.timestamp)) check.Fail(at + "/timestamp", "not a finite number");
    check.CheckPose(at + "/cam_from_world", kf.cam_from_world);
    for (std::size_t i = 0; i < kf.line_ids.size(); ++i) {
      if (!map.lines.count(kf.line_ids[i])) {
        check.Fail(at + "/line_ids/" + std::to_string(i),
                   "no line with id " + std::to_string(kf.line_ids[i]));
      }
    }
  }
  ordinal = 0;
  for (const auto& [id, point] : map.points) {
    const std::string at = check.Where("points", locator.points, id, ordinal++);
    check.CheckBounded(at + "/position", point.position.data(), 3, kMaxCoordinate);
    check.CheckSymmetricPsd(at + "/covariance", point.covariance);
    check_observations(at, point.observations);
  }
  ordinal = 0;
  for (const auto& [id, line] : map.lines) {
    const std::string at = check.Where("lines", locator.lines, id, ordinal++);
    check.CheckBounded(at + "/anchor", line.line.anchor.data(), 3, kMaxCoordinate);
    check.CheckFinite(at + "/direction", line.line.direction.data(), 3);
    check.CheckUnit(at + "/direction", line.line.direction.norm());
    check.CheckSymmetricPsd(at + "/information", line.information);
    const double info_norm = line.information.norm();
    if ((line.information * line.line.direction).norm() > kNullSpaceTolerance * info_norm) {
      check.Fail(at + "/information", "the line direction is not in its null space");
    }
    if (line.restored_point)
      check.CheckBounded(at + "/restored_point", line.restored_point->data(), 3, kMaxCoordinate);
    for (std::size_t i = 0; i < line.server_keyframe_ids.size(); ++i) {
      if (!map.server_keyframes.count(line.server_keyframe_ids[i])) {
        check.Fail(at + "/server_keyframe_ids/" + std::to_string(i),
                   "no server keyframe with id " + std::to_string(line.server_keyframe_ids[i]));
      }
    }
    check_observations(at, line.observations);
  }
  for (std::size_t i = 0; i < map.loop_edges.size(); ++i) {
    const auto& [a, b] = map.loop_edges[i];
    const std::string at = "/loop_edges/" + std::to_string(i);
    if (!map.keyframes.count(a)) check.Fail(at + "/0", "no keyframe with id " + std::to_string(a));
    if (!map.keyframes.count(b)) check.Fail(at + "/1", "no keyframe with id " + std::to_string(b));
    if (a == b) check.Fail(at, "a loop edge joins two different keyframes");
  }
}

}  // namespace internal

void ValidateMap(const slam::Map& map, const std::string& source_name) {
  internal::ValidateMapAt(map, source_name, internal::EntityLocator{});
}

}  // namespace lcv::mapping
