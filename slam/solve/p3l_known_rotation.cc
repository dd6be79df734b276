#include "slam/solve/p3l_known_rotation.h"

#include <Eigen/SVD>

#include "slam/util/error.h"

namespace lcv::slam {

std::optional<Rigid3d> SolveCentreKnownRotation(const Eigen::Quaterniond& cam_from_world_rotation,
                                                const Eigen::Vector3d* bearings,
                                                const Line3d* world_lines,
                                                const std::vector<int>& indices) {
  if (indices.size() < 3) return std::nullopt;
  const Eigen::Matrix3d world_from_cam = cam_from_world_rotation.conjugate().toRotationMatrix();
  // Normal equations of (1) with unit plane normals (each equation an angle-like residual).
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (const int i : indices) {
    Eigen::Vector3d n = world_lines[i].direction.cross(world_from_cam * bearings[i]);
    const double norm = n.norm();
    if (!(norm > 1e-12)) continue;  // the ray runs along its line: no constraint
    n /= norm;
    A += n * n.transpose();
    rhs += n * n.dot(world_lines[i].anchor);
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(A, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d s = svd.singularValues();
  if (!(s(0) > 0.0) || s(2) < 1e-9 * s(0)) return std::nullopt;
  const Eigen::Vector3d centre = svd.solve(rhs);
  if (!centre.allFinite()) return std::nullopt;
  return Rigid3d(cam_from_world_rotation, -(cam_from_world_rotation * centre));
}

void CentreKnownRotationEstimator::Estimate(const std::vector<int>& sample,
                                            std::vector<Model>* models) const {
  models->clear();
  if (const auto pose = SolveCentreKnownRotation(rotation_, bearings_, lines_, sample)) {
    models->push_back(*pose);
  }
}

void CentreKnownRotationEstimator::Residuals(const Model& cam_from_world,
                                             std::vector<double>* squared_residuals) const {
  squared_residuals->resize(count_);
  for (int i = 0; i < count_; ++i) {
    (*squared_residuals)[i] = SquaredBearingPlaneError(cam_from_world, bearings_[i], lines_[i]);
  }
}

bool CentreKnownRotationEstimator::Refine(const std::vector<int>& inliers,
                                          Model* cam_from_world) const {
  const auto pose = SolveCentreKnownRotation(rotation_, bearings_, lines_, inliers);
  if (!pose) return false;
  *cam_from_world = *pose;
  return true;
}

P6LResult EstimatePoseKnownRotation(const std::vector<Eigen::Vector3d>& bearings,
                                    const std::vector<Line3d>& world_lines,
                                    const Eigen::Quaterniond& cam_from_world_rotation,
                                    const P6LOptions& options) {
  LCV_CHECK(bearings.size() == world_lines.size()) << "bearings and lines differ in count";
  RansacOptions ransac = options.ransac;
  if (!(ransac.max_error > 0.0)) ransac.max_error = options.max_angular_error_rad;
  const CentreKnownRotationEstimator estimator(cam_from_world_rotation, bearings.data(),
                                               world_lines.data(),
                                               static_cast<int>(bearings.size()));
  return RefineLineCloudPose(Ransac(ransac, estimator), bearings, world_lines, options,
                             ransac.max_error);
}

}  // namespace lcv::slam
