#pragma once
// A deterministic synthetic point map with ground truth, for tests, audits, demos and renders.
//
// Scene (world frame = the first camera's axes: x right, y down, z forward; metres): a straight
// street along +z between two building facades at x = -street_half_width_m and
// x = +street_half_width_m, rising from the ground plane y = camera_height_m up to
// y = camera_height_m - facade_height_m, plus "clutter" points (poles, cars, trees) scattered in
// the free space beside the driving lane. The camera drives along z at camera height (y = 0),
// weaving slightly in x and yawing with its path.
//
// The returned map is a *client* point map:
// - one perspective camera (no distortion), id 1;
// - num_keyframes keyframes with their true poses (cam_from_world), ids 2..num_keyframes+1;
// - num_points points with their TRUE positions (ground truth), ids after the keyframes, each
//   seen by at least min_observations keyframes (projection in the image, depth in range;
//   occlusion is not modelled);
// - per keyframe one keypoint per observed point: the true projection plus Gaussian pixel noise
//   (octave 0, random orientation), and one descriptor per keypoint: the point's random 256-bit
//   ORB-like descriptor with a few bits flipped;
// - observations consistent both ways: point.observations[k] = {kf, i} <=> keyframe kf's
//   keypoint i was made from that point;
// - covariances to first order from the observing rays:
//     Sigma_X = (sum_k J_k^T J_k / sigma_px^2 + I / prior_sigma_m^2)^-1,
//   J_k = d(pixel)/d(X) of keyframe k; the weak prior keeps Sigma_X finite for short baselines.
//
// Same options (same seed) -> bit-identical map on one platform.

#include <cstdint>
#include <optional>
#include <string>

#include "slam/data/map.h"

namespace lcv::mapping {

struct SyntheticMapOptions {
  int num_points = 2000;
  int num_keyframes = 30;
  std::uint64_t seed = 0;
  // Standard deviation of the Gaussian noise added to each keypoint, px. 0 gives exact keypoints.
  double pixel_noise_px = 1.0;
  // Sigma used for the covariances, px; <= 0 means max(pixel_noise_px, 0.5).
  double covariance_sigma_px = 0.0;
  // Prior on every point (regularization of Sigma_X), metres.
  double prior_sigma_m = 10.0;

  // Camera: 640x360, fx = fy = focal_px, principal point at the image centre.
  int cols = 640;
  int rows = 360;
  double focal_px = 450.0;

  // Scene and path, metres.
  double street_half_width_m = 6.0;
  double facade_height_m = 10.0;
  double camera_height_m = 1.6;
  double keyframe_spacing_m = 1.0;  // distance along z between consecutive keyframes
  double weave_amplitude_m = 0.5;   // lateral sinusoidal weave of the path
  double max_depth_m = 40.0;        // farther points are not observed
  double min_depth_m = 0.5;

  // Share of points that are clutter off the three planes, in [0, 1].
  double clutter_fraction = 0.1;
  // Points seen by fewer keyframes are rejected and re-drawn.
  int min_observations = 2;
  // Each observation's descriptor differs from its point's in 0..max_descriptor_bit_flips bits.
  int max_descriptor_bit_flips = 8;

  // Empty when usable, else what is wrong ("num_points must be > 0").
  std::optional<std::string> Problem() const;
};

// Which surface a synthetic point was drawn on, recoverable from its position (for tests).
enum class SyntheticSurface { kLeftFacade, kRightFacade, kGround, kClutter };
SyntheticSurface ClassifySyntheticPoint(const SyntheticMapOptions& options,
                                        const Eigen::Vector3d& p_in_world);

// Precondition: !options.Problem() (checked, std::logic_error). Throws std::runtime_error when
// the scene cannot yield num_points points seen min_observations times (e.g. one keyframe and
// min_observations 2) after a bounded number of draws.
slam::Map MakeSyntheticPointMap(const SyntheticMapOptions& options);

}  // namespace lcv::mapping
