#include "mapping/synthetic_map.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using slam::Id;

constexpr double kPlaneTolerance = 1e-9;

// Path of the camera centre and its yaw (rotation about the world y axis) at keyframe index i.
struct PathSample {
  Eigen::Vector3d center;
  double yaw_rad;
};

PathSample PathAt(const SyntheticMapOptions& o, int i) {
  const double z = i * o.keyframe_spacing_m;
  // One full weave over 30 m: enough parallax in x, gentle enough to stay in the lane.
  const double phase = 2.0 * M_PI * z / 30.0;
  const double x = o.weave_amplitude_m * std::sin(phase);
  const double dx_dz = o.weave_amplitude_m * 2.0 * M_PI / 30.0 * std::cos(phase);
  // Heading follows the path tangent: x grows to the right of +z, so yaw = atan(dx/dz) about +y
  // (y points down: a positive rotation about +y turns +z towards +x).
  return {Eigen::Vector3d(x, 0.0, z), std::atan(dx_dz)};
}

slam::Rigid3d CamFromWorldAt(const SyntheticMapOptions& o, int i) {
  const PathSample s = PathAt(o, i);
  const Eigen::Quaterniond world_from_cam_rotation(
      Eigen::AngleAxisd(s.yaw_rad, Eigen::Vector3d::UnitY()));
  return slam::Rigid3d(world_from_cam_rotation, s.center).Inverse();
}

struct Projection {
  Eigen::Vector2d px;
  Eigen::Matrix3d J_px_world_rows;  // rows 0,1 = d(px)/d(p_in_world); row 2 unused
};

class SceneSampler {
 public:
  SceneSampler(const SyntheticMapOptions& o, std::mt19937_64* rng) : o_(o), rng_(rng) {
    const double path_length = (o.num_keyframes - 1) * o.keyframe_spacing_m;
    z_min_ = -5.0;
    z_max_ = path_length + 0.8 * o.max_depth_m;
    ground_y_ = o.camera_height_m;
    top_y_ = o.camera_height_m - o.facade_height_m;
  }

  Eigen::Vector3d Draw() {
    const double hw = o_.street_half_width_m;
    if (Uniform() < o_.clutter_fraction) {
      // Clutter beside the lane: |x| in [2, hw - 0.5], up to 4 m above the ground.
      const double side = Uniform() < 0.5 ? -1.0 : 1.0;
      const double x = side * (2.0 + Uniform() * std::max(0.0, hw - 2.5));
      const double y = ground_y_ - 4.0 * Uniform();
      return Eigen::Vector3d(x, y, Lerp(z_min_, z_max_, Uniform()));
    }
    // Facades and ground, proportionally to their widths (areas per metre of street).
    const double left = o_.facade_height_m, right = o_.facade_height_m, ground = 2.0 * hw;
    const double pick = Uniform() * (left + right + ground);
    const double z = Lerp(z_min_, z_max_, Uniform());
    if (pick < left) return Eigen::Vector3d(-hw, Lerp(top_y_, ground_y_, Uniform()), z);
    if (pick < left + right) return Eigen::Vector3d(hw, Lerp(top_y_, ground_y_, Uniform()), z);
    return Eigen::Vector3d(Lerp(-hw, hw, Uniform()), ground_y_, z);
  }

  double Uniform() { return std::uniform_real_distribution<double>(0.0, 1.0)(*rng_); }

 private:
  static double Lerp(double a, double b, double t) { return a + (b - a) * t; }

  const SyntheticMapOptions& o_;
  std::mt19937_64* rng_;
  double z_min_, z_max_, ground_y_, top_y_;
};

}  // namespace

std::optional<std::string> SyntheticMapOptions::Problem() const {
  auto finite_positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (num_points <= 0) return "num_points must be > 0";
  if (num_keyframes <= 0) return "num_keyframes must be > 0";
  if (!(std::isfinite(pixel_noise_px) && pixel_noise_px >= 0.0)) {
    return "pixel_noise_px must be finite and >= 0";
  }
  if (!std::isfinite(covariance_sigma_px)) return "covariance_sigma_px must be finite";
  if (!finite_positive(prior_sigma_m)) return "prior_sigma_m must be > 0";
  if (cols <= 0 || rows <= 0) return "cols and rows must be > 0";
  if (!finite_positive(focal_px)) return "focal_px must be > 0";
  if (!(finite_positive(street_half_width_m) && street_half_width_m > 2.5)) {
    return "street_half_width_m must be > 2.5";
  }
  if (!finite_positive(facade_height_m)) return "facade_height_m must be > 0";
  if (!std::isfinite(camera_height_m)) return "camera_height_m must be finite";
  if (!finite_positive(keyframe_spacing_m)) return "keyframe_spacing_m must be > 0";
  if (!(std::isfinite(weave_amplitude_m) && std::abs(weave_amplitude_m) < 1.5)) {
    return "weave_amplitude_m must be in (-1.5, 1.5) (the lane)";
  }
  if (!finite_positive(min_depth_m)) return "min_depth_m must be > 0";
  if (!(std::isfinite(max_depth_m) && max_depth_m > min_depth_m)) {
    return "max_depth_m must be > min_depth_m";
  }
  if (!(clutter_fraction >= 0.0 && clutter_fraction <= 1.0)) {
    return "clutter_fraction must be in [0, 1]";
  }
  if (min_observations < 1) return "min_observations must be >= 1";
  if (min_observations > num_keyframes) return "min_observations must be <= num_keyframes";
  if (max_descriptor_bit_flips < 0 || max_descriptor_bit_flips > 256) {
    return "max_descriptor_bit_flips must be in [0, 256]";
  }
  return std::nullopt;
}

SyntheticSurface ClassifySyntheticPoint(const SyntheticMapOptions& options,
                                        const Eigen::Vector3d& p_in_world) {
  const double hw = options.street_half_width_m;
  if (std::abs(p_in_world.x() + hw) < kPlaneTolerance) return SyntheticSurface::kLeftFacade;
  if (std::abs(p_in_world.x() - hw) < kPlaneTolerance) return SyntheticSurface::kRightFacade;
  if (std::abs(p_in_world.y() - options.camera_height_m) < kPlaneTolerance) {
    return SyntheticSurface::kGround;
  }
  return SyntheticSurface::kClutter;
}

slam::Map MakeSyntheticPointMap(const SyntheticMapOptions& options) {
  const auto problem = options.Problem();
  LCV_CHECK(!problem) << *problem;
  const SyntheticMapOptions& o = options;
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> pixel_noise(0.0, 1.0);
  std::uniform_int_distribution<int> byte_dist(0, 255);

  slam::Map map;
  map.description = "lcv synthetic street map (seed " + std::to_string(o.seed) + ")";

  const Id camera_id = 1;
  slam::CameraParams camera;
  camera.name = "synthetic";
  camera.model = slam::CameraModel::kPerspective;
  camera.cols = o.cols;
  camera.rows = o.rows;
  camera.fx = camera.fy = o.focal_px;
  camera.cx = 0.5 * (o.cols - 1);
  camera.cy = 0.5 * (o.rows - 1);
  camera.fps = 10.0;
  map.cameras[camera_id] = camera;

  // Keyframes first: their poses decide which drawn points are kept.
  std::vector<slam::Rigid3d> cam_from_world(o.num_keyframes);
  std::vector<Eigen::Matrix3d> rotations(o.num_keyframes);
  for (int k = 0; k < o.num_keyframes; ++k) {
    cam_from_world[k] = CamFromWorldAt(o, k);
    rotations[k] = cam_from_world[k].RotationMatrix();
    slam::Keyframe kf;
    kf.id = 2 + static_cast<Id>(k);
    kf.camera_id = camera_id;
    kf.timestamp = k / camera.fps;
    kf.cam_from_world = cam_from_world[k];
    map.keyframes[kf.id] = std::move(kf);
  }
  const Id first_point_id = 2 + static_cast<Id>(o.num_keyframes);

  const double sigma_px =
      o.covariance_sigma_px > 0.0 ? o.covariance_sigma_px : std::max(o.pixel_noise_px, 0.5);
  const double info_per_px2 = 1.0 / (sigma_px * sigma_px);
  const Eigen::Matrix3d prior_info =
      Eigen::Matrix3d::Identity() / (o.prior_sigma_m * o.prior_sigma_m);

  SceneSampler sampler(o, &rng);
  struct Visible {
    int keyframe_index;
    Eigen::Vector2d px;
  };
  std::vector<Visible> visible;
  visible.reserve(o.num_keyframes);
  const std::int64_t max_draws = 500LL * o.num_points + 10000;
  std::int64_t draws = 0;
  Id next_point_id = first_point_id;
  while (static_cast<int>(map.points.size()) < o.num_points) {
    if (++draws > max_draws) {
      throw std::runtime_error(
          "MakeSyntheticPointMap: could not place " + std::to_string(o.num_points) +
          " points seen by >= " + std::to_string(o.min_observations) + " keyframes");
    }
    const Eigen::Vector3d p_in_world = sampler.Draw();
    visible.clear();
    Eigen::Matrix3d info = prior_info;
    for (int k = 0; k < o.num_keyframes; ++k) {
      const Eigen::Vector3d p = cam_from_world[k] * p_in_world;
      if (p.z() < o.min_depth_m || p.norm() > o.max_depth_m) continue;
      const double inv_z = 1.0 / p.z();
      const Eigen::Vector2d px(camera.fx * p.x() * inv_z + camera.cx,
                               camera.fy * p.y() * inv_z + camera.cy);
      if (px.x() < 0.0 || px.y() < 0.0 || px.x() > o.cols - 1 || px.y() > o.rows - 1) continue;
      Eigen::Matrix<double, 2, 3> J_px_p;
      J_px_p << camera.fx * inv_z, 0.0, -camera.fx * p.x() * inv_z * inv_z,  //
          0.0, camera.fy * inv_z, -camera.fy * p.y() * inv_z * inv_z;
      const Eigen::Matrix<double, 2, 3> J_px_world = J_px_p * rotations[k];
      info.noalias() += info_per_px2 * J_px_world.transpose() * J_px_world;
      visible.push_back({k, px});
    }
    if (static_cast<int>(visible.size()) < o.min_observations) continue;

    slam::PointLandmark point;
    point.id = next_point_id++;
    point.position = p_in_world;
    const Eigen::Matrix3d covariance = info.ldlt().solve(Eigen::Matrix3d::Identity());
    point.covariance = 0.5 * (covariance + covariance.transpose());
    slam::OrbDescriptor descriptor;
    for (auto& byte : descriptor) byte = static_cast<std::uint8_t>(byte_dist(rng));
    point.descriptor = descriptor;
    point.observations.reserve(visible.size());
    for (const Visible& v : visible) {
      slam::Keyframe& kf = map.keyframes.at(2 + static_cast<Id>(v.keyframe_index));
      slam::Keypoint keypoint;
      keypoint.x = static_cast<float>(v.px.x() + o.pixel_noise_px * pixel_noise(rng));
      keypoint.y = static_cast<float>(v.px.y() + o.pixel_noise_px * pixel_noise(rng));
      keypoint.angle_deg = static_cast<float>(360.0 * sampler.Uniform());
      if (keypoint.angle_deg >= 360.f) keypoint.angle_deg = 0.f;
      keypoint.octave = 0;
      slam::OrbDescriptor observed = descriptor;
      const int flips = std::uniform_int_distribution<int>(0, o.max_descriptor_bit_flips)(rng);
      for (int f = 0; f < flips; ++f) {
        // Bits may repeat, so the Hamming distance is <= flips.
        const int bit = std::uniform_int_distribution<int>(0, 255)(rng);
        observed[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      }
      point.observations.push_back({kf.id, static_cast<std::uint32_t>(kf.keypoints.size())});
      kf.keypoints.push_back(keypoint);
      kf.descriptors.push_back(observed);
    }
    map.points[point.id] = std::move(point);
  }
  return map;
}

}  // namespace lcv::mapping
