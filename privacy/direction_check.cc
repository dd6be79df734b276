#include "privacy/direction_check.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "privacy/statistics.h"

namespace lcv::privacy {

std::vector<Eigen::Vector3d> DominantPlaneNormals(const std::vector<Eigen::Vector3d>& points,
                                                  const DirectionCheckOptions& options) {
  std::vector<Eigen::Vector3d> normals;
  if (points.size() < 3) return normals;
  Eigen::AlignedBox3d box;
  for (const auto& p : points) box.extend(p);
  const double threshold = options.plane_inlier_fraction * std::max(box.diagonal().norm(), 1e-12);
  const std::size_t min_support =
      std::max<std::size_t>(3, static_cast<std::size_t>(options.min_plane_support * points.size()));
  std::vector<Eigen::Vector3d> remaining = points;
  std::mt19937_64 rng(options.seed);
  for (int plane = 0; plane < options.max_planes && remaining.size() >= min_support; ++plane) {
    std::uniform_int_distribution<std::size_t> pick(0, remaining.size() - 1);
    std::size_t best_support = 0;
    Eigen::Vector3d best_normal = Eigen::Vector3d::Zero();
    double best_offset = 0.0;
    for (int it = 0; it < options.ransac_iterations; ++it) {
      const Eigen::Vector3d& a = remaining[pick(rng)];
      const Eigen::Vector3d& b = remaining[pick(rng)];
      const Eigen::Vector3d& c = remaining[pick(rng)];
      Eigen::Vector3d normal = (b - a).cross(c - a);
      if (normal.norm() < 1e-12) continue;
      normal.normalize();
      const double offset = normal.dot(a);
      std::size_t support = 0;
      for (const auto& p : remaining) support += std::abs(normal.dot(p) - offset) < threshold;
      if (support > best_support) {
        best_support = support;
        best_normal = normal;
        best_offset = offset;
      }
    }
    if (best_support < min_support) break;
    // Least-squares refit on the inliers.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> inliers, outliers;
    for (const auto& p : remaining) {
      (std::abs(best_normal.dot(p) - best_offset) < threshold ? inliers : outliers).push_back(p);
    }
    for (const auto& p : inliers) mean += p;
    mean /= static_cast<double>(inliers.size());
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const auto& p : inliers) scatter += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
    normals.push_back(eig.eigenvectors().col(0).normalized());
    remaining.swap(outliers);
  }
  return normals;
}

DirectionCheckResult CheckDirections(const slam::Map& map, const slam::Map* reference,
                                     const DirectionCheckOptions& options) {
  DirectionCheckResult out;
  std::vector<Eigen::Vector3d> directions;
  directions.reserve(map.lines.size());
  for (const auto& [id, l] : map.lines) directions.push_back(l.line.direction.normalized());
  if (directions.size() < 8) {
    out.alpha_per_test = options.alpha;
    return out;
  }
  auto add_sphere = [&](const std::string& name, const SphereTestResult& r) {
    DirectionTest t;
    t.name = name;
    t.statistic = r.statistic;
    t.p_value = r.p_value;
    t.count = r.count;
    out.tests.push_back(t);
  };
  add_sphere("rayleigh", RayleighTest(directions));
  add_sphere("bingham", BinghamTest(directions));

  std::vector<std::pair<std::string, Eigen::Vector3d>> axes;
  if (reference && !reference->points.empty()) {
    std::vector<Eigen::Vector3d> points;
    points.reserve(reference->points.size());
    for (const auto& [id, p] : reference->points) points.push_back(p.position);
    const auto normals = DominantPlaneNormals(points, options);
    for (std::size_t k = 0; k < normals.size(); ++k) {
      axes.emplace_back("ks_plane_normal_" + std::to_string(k), normals[k]);
    }
  }
  const std::map<slam::Id, slam::ServerKeyframe>& kfs = map.server_keyframes;
  if (!kfs.empty()) {
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    for (const auto& [id, kf] : kfs) {
      sum += kf.cam_from_world.rotation.conjugate().toRotationMatrix();  // world_from_cam
    }
    // Closest rotation to the mean: its columns are the mean right, down and viewing axes.
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d mean = svd.matrixU() * svd.matrixV().transpose();
    const char* names[3] = {"ks_keyframe_right", "ks_keyframe_down", "ks_keyframe_view"};
    for (int a = 0; a < 3; ++a) axes.emplace_back(names[a], mean.col(a).normalized());
  }
  std::vector<double> u(directions.size());
  for (const auto& [name, axis] : axes) {
    for (std::size_t i = 0; i < directions.size(); ++i) u[i] = std::abs(directions[i].dot(axis));
    const KsResult ks = KolmogorovSmirnovUniform(u, 0.0, 1.0);
    DirectionTest t;
    t.name = name;
    t.statistic = ks.statistic;
    t.p_value = ks.p_value;
    t.count = ks.count;
    t.axis = axis;
    out.tests.push_back(t);
  }
  out.alpha_per_test = options.alpha / static_cast<double>(out.tests.size());
  for (const auto& t : out.tests) out.passed = out.passed && t.p_value >= out.alpha_per_test;
  return out;
}

}  // namespace lcv::privacy
