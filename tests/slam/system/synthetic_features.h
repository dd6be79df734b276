#pragma once
// Purely geometric synthetic input for the SLAM engine's tests (no images, no ORB extractor):
// 3D points with random 256-bit descriptors, a known camera trajectory, and per frame the
// keypoints a perfect detector would report (projection + pixel noise, a few flipped descriptor
// bits, optional clutter keypoints with random descriptors). Header-only, seeded.

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/rigid3.h"
#include "slam/geometry/so3.h"

namespace lcv::slam::testing {

struct SyntheticScene {
  std::vector<Eigen::Vector3d> points_in_world;
  std::vector<OrbDescriptor> descriptors;
};

inline OrbDescriptor RandomDescriptor(std::mt19937_64* rng) {
  OrbDescriptor d;
  for (auto& byte : d) byte = static_cast<std::uint8_t>((*rng)() & 0xff);
  return d;
}

// Points in a slab in front of a camera that looks along +z and moves along +x: x in
// [x_min, x_max], y in [-2.5, 2.5], z in [z_min, z_max] (metres).
inline SyntheticScene MakeSlabScene(int count, double x_min, double x_max, double z_min,
                                    double z_max, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(x_min, x_max), uy(-2.5, 2.5), uz(z_min, z_max);
  SyntheticScene scene;
  for (int i = 0; i < count; ++i) {
    scene.points_in_world.emplace_back(ux(rng), uy(rng), uz(rng));
    scene.descriptors.push_back(RandomDescriptor(&rng));
  }
  return scene;
}

// cam_from_world of frame i: centre (step * i, 0.1 sin(i / 7), 0.05 sin(i / 11)), a gentle yaw
// and pitch wobble; the camera looks along +z.
inline std::vector<Rigid3d> MakeLateralTrajectory(int frames, double step_m) {
  std::vector<Rigid3d> poses;
  for (int i = 0; i < frames; ++i) {
    const Eigen::Vector3d center(step_m * i, 0.1 * std::sin(i / 7.0), 0.05 * std::sin(i / 11.0));
    const Eigen::Vector3d omega(0.02 * std::sin(i / 9.0), 0.03 * std::sin(i / 13.0), 0.0);
    const Eigen::Quaterniond world_from_cam_rotation = ExpSO3(omega);
    const Rigid3d world_from_cam(world_from_cam_rotation, center);
    poses.push_back(world_from_cam.Inverse());
  }
  return poses;
}

struct SyntheticFrame {
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  std::vector<int> point_index;  // per keypoint: the scene point, or -1 for clutter
};

struct ObservationNoise {
  double pixel_sigma = 0.5;
  int flipped_bits = 4;  // per observation
  int clutter = 50;      // random keypoints with random descriptors
};

inline SyntheticFrame ObserveScene(const SyntheticScene& scene, const Camera& camera,
                                   const Rigid3d& cam_from_world, const ObservationNoise& noise,
                                   std::mt19937_64* rng) {
  SyntheticFrame frame;
  std::normal_distribution<double> pixel(0.0, noise.pixel_sigma);
  std::uniform_int_distribution<int> bit(0, 255);
  for (size_t j = 0; j < scene.points_in_world.size(); ++j) {
    const Eigen::Vector3d p_in_cam = cam_from_world * scene.points_in_world[j];
    if (p_in_cam.z() <= 0.1) continue;
    const auto px = camera.Project(p_in_cam);
    if (!px) continue;
    const Eigen::Vector2d noisy = *px + Eigen::Vector2d(pixel(*rng), pixel(*rng));
    if (!camera.InImage(noisy, 2.0)) continue;
    Keypoint kp;
    kp.x = static_cast<float>(noisy.x());
    kp.y = static_cast<float>(noisy.y());
    kp.angle_deg = 0.f;
    kp.octave = 0;
    OrbDescriptor d = scene.descriptors[j];
    for (int b = 0; b < noise.flipped_bits; ++b) {
      const int k = bit(*rng);
      d[k / 8] ^= static_cast<std::uint8_t>(1u << (k % 8));
    }
    frame.keypoints.push_back(kp);
    frame.descriptors.push_back(d);
    frame.point_index.push_back(static_cast<int>(j));
  }
  std::uniform_real_distribution<double> ux(2.0, camera.cols() - 3.0), uy(2.0, camera.rows() - 3.0);
  for (int c = 0; c < noise.clutter; ++c) {
    Keypoint kp;
    kp.x = static_cast<float>(ux(*rng));
    kp.y = static_cast<float>(uy(*rng));
    kp.angle_deg = 0.f;
    frame.keypoints.push_back(kp);
    frame.descriptors.push_back(RandomDescriptor(rng));
    frame.point_index.push_back(-1);
  }
  return frame;
}

inline CameraParams SyntheticPinhole(int cols = 640, int rows = 480, double f = 500.0) {
  CameraParams params;
  params.name = "synthetic";
  params.model = CameraModel::kPerspective;
  params.cols = cols;
  params.rows = rows;
  params.fx = params.fy = f;
  params.cx = 0.5 * (cols - 1);
  params.cy = 0.5 * (rows - 1);
  return params;
}

}  // namespace lcv::slam::testing
