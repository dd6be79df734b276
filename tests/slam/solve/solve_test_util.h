#pragma once
// Synthetic scenes for the solver tests: random poses, points in front of cameras, bearings
// with angular noise, outliers. Seeded, so a failure reproduces.

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/geometry/sim3.h"
#include "slam/geometry/so3.h"

namespace lcv::slam::test {

inline Eigen::Quaterniond RandomRotation(std::mt19937_64& rng, double max_angle_rad = 3.14) {
  std::normal_distribution<double> normal;
  Eigen::Vector3d axis(normal(rng), normal(rng), normal(rng));
  axis.normalize();
  std::uniform_real_distribution<double> angle(-max_angle_rad, max_angle_rad);
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle(rng), axis));
}

// A unit bearing perturbed by a random rotation of exactly angle_rad about an axis orthogonal
// to it (angle 0: unchanged).
inline Eigen::Vector3d PerturbBearing(const Eigen::Vector3d& bearing, double sigma_rad,
                                      std::mt19937_64& rng) {
  if (sigma_rad <= 0.0) return bearing.normalized();
  std::normal_distribution<double> normal(0.0, sigma_rad);
  const Eigen::Vector3d b = bearing.normalized();
  Eigen::Vector3d helper = std::abs(b.x()) < 0.9 ? Eigen::Vector3d::UnitX()
                                                  : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d e1 = (helper - b.dot(helper) * b).normalized();
  const Eigen::Vector3d e2 = b.cross(e1);
  return (b + normal(rng) * e1 + normal(rng) * e2).normalized();
}

// A uniformly random unit vector.
inline Eigen::Vector3d RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
}

// Random point in camera-frame directions within half_fov_rad of +z, depth in [near, far];
// returns it in the camera frame.
inline Eigen::Vector3d RandomPointInView(std::mt19937_64& rng, double half_fov_rad, double near,
                                         double far) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double cos_max = std::cos(half_fov_rad);
  const double z = cos_max + (1.0 - cos_max) * uniform(rng);
  const double phi = 2.0 * 3.14159265358979 * uniform(rng);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const Eigen::Vector3d direction(r * std::cos(phi), r * std::sin(phi), z);
  return direction * (near + (far - near) * uniform(rng));
}

inline double TranslationAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Client points X in a 10-unit box and, for each, a server line through server_from_client * X
// (plus noise) with a random direction and a random anchor along it, as a line cloud publishes
// them; the first outlier_ratio * n lines pass through random points instead.
struct PointLineScene {
  Sim3d server_from_client;
  std::vector<Eigen::Vector3d> points;  // client frame
  std::vector<Line3d> lines;            // server frame
  std::vector<char> is_inlier;
};

inline PointLineScene MakePointLineScene(std::uint64_t seed, int n, double noise,
                                         double outlier_ratio) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-5.0, 5.0);
  std::normal_distribution<double> normal(0.0, noise);
  PointLineScene scene;
  scene.server_from_client =
      Sim3d(0.5 + 2.0 * std::uniform_real_distribution<double>(0, 1)(rng), RandomRotation(rng),
            RandomUnit(rng) * 4.0);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d X(uniform(rng), uniform(rng), uniform(rng));
    const bool outlier = i < outlier_ratio * n;
    Eigen::Vector3d Y = scene.server_from_client * X;
    if (outlier) Y = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)) * 3.0;
    Y += Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d d = RandomUnit(rng);
    scene.points.push_back(X);
    scene.lines.emplace_back(Y + uniform(rng) * d, d);
    scene.is_inlier.push_back(!outlier);
  }
  return scene;
}

// |s_a - s_b| + rotation angle + translation distance: one number to compare similarities.
inline double Sim3Error(const Sim3d& a, const Sim3d& b) {
  return std::abs(a.scale - b.scale) + AngularDistance(a.rotation, b.rotation) +
         (a.translation - b.translation).norm();
}

// A line cloud seen by one camera: n hidden points 1-8 m away within half_fov_rad of the
// camera's +z, at a random pose, each turned into a line of random direction (its anchor moved
// along it); outliers (the first outlier_ratio * n) get a random bearing instead of the point's.
struct LineScene {
  Rigid3d cam_from_world;
  std::vector<Eigen::Vector3d> bearings;
  std::vector<Line3d> lines;  // world frame
  std::vector<char> is_inlier;
};

inline LineScene MakeLineScene(std::uint64_t seed, double half_fov_rad, int n, double noise_rad,
                               double outlier_ratio) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  LineScene scene;
  const Rigid3d world_from_cam(RandomRotation(rng),
                               Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng)) * 5.0);
  scene.cam_from_world = world_from_cam.Inverse();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d x_cam = RandomPointInView(rng, half_fov_rad, 1.0, 8.0);
    const Eigen::Vector3d direction = RandomUnit(rng);
    const Eigen::Vector3d x_world = world_from_cam * x_cam;
    scene.lines.emplace_back(x_world + 3.0 * uniform(rng) * direction, direction);
    const bool outlier = i < outlier_ratio * n;
    Eigen::Vector3d bearing = outlier ? RandomUnit(rng) : x_cam.normalized();
    scene.bearings.push_back(PerturbBearing(bearing, noise_rad, rng));
    scene.is_inlier.push_back(!outlier);
  }
  return scene;
}

}  // namespace lcv::slam::test
