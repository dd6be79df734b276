#include "slam/solve/triangulation.h"

#include <cmath>

namespace lcv::slam {

std::optional<TriangulatedPoint> TriangulateBearings(const Rigid3d& cam1_from_world,
                                                     const Rigid3d& cam2_from_world,
                                                     const Eigen::Vector3d& bearing1,
                                                     const Eigen::Vector3d& bearing2,
                                                     double min_parallax_rad) {
  // Rays in the world frame: c_i + s_i * d_i.
  const Eigen::Vector3d c1 = cam1_from_world.Center();
  const Eigen::Vector3d c2 = cam2_from_world.Center();
  const Eigen::Vector3d d1 = cam1_from_world.rotation.conjugate() * bearing1.normalized();
  const Eigen::Vector3d d2 = cam2_from_world.rotation.conjugate() * bearing2.normalized();
  const Eigen::Vector3d baseline = c2 - c1;

  // Closest points: minimize |c1 + s1 d1 - c2 - s2 d2|^2 ->
  //   [1, -b; b, -1] [s1; s2] = [d1.baseline; d2.baseline], b = d1.d2.
  const double b = d1.dot(d2);
  const double denominator = 1.0 - b * b;  // sin^2 of the angle between the rays
  if (!(denominator > 1e-14)) return std::nullopt;
  const double e1 = d1.dot(baseline);
  const double e2 = d2.dot(baseline);
  const double s1 = (e1 - b * e2) / denominator;
  const double s2 = (b * e1 - e2) / denominator;
  if (!(s1 > 0.0) || !(s2 > 0.0)) return std::nullopt;

  TriangulatedPoint out;
  out.point_in_world = 0.5 * (c1 + s1 * d1 + c2 + s2 * d2);
  const Eigen::Vector3d ray1 = out.point_in_world - c1;
  const Eigen::Vector3d ray2 = out.point_in_world - c2;
  out.depth1 = ray1.dot(d1);
  out.depth2 = ray2.dot(d2);
  if (!(out.depth1 > 0.0) || !(out.depth2 > 0.0)) return std::nullopt;
  out.parallax_rad = std::atan2(ray1.cross(ray2).norm(), ray1.dot(ray2));
  if (!(out.parallax_rad >= min_parallax_rad)) return std::nullopt;
  if (!out.point_in_world.allFinite()) return std::nullopt;
  return out;
}

}  // namespace lcv::slam
