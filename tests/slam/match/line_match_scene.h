#pragma once
// A synthetic line-cloud tracking scene with a known answer, shared by
// tests/slam/match/line_projection_matcher_test.cc and bench/bench_line_matching.cc.
//
// Hidden 3D points with ORB-like descriptors become published lines: a random direction through
// each point, the anchor re-drawn as the point of the line closest to the world origin (as
// mapping/line_cloud.h publishes them). Each line's search interval [s_min, s_max] comes from
// LineVisibleInterval over the server keyframes that see its hidden point: a few keyframes near
// the client, plus, for a point none of them sees, one keyframe of the local window looking at it.
// The client frame's keypoints are the projections of a random subset of the visible hidden
// points (+ pixel noise, descriptors with flipped bits) and clutter keypoints.
//
// Descriptors are ORB-like rather than uniform: they are drawn around a few prototypes (real
// ORB descriptors of different corners are often 60-90 bits apart, not 128), so the ratio test
// and the distance threshold meet look-alike clutter along each line's corridor.
// Units: metres, pixels. Header-only, seeded: the same options give the same scene.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "render/synth_scenario.h"
#include "slam/camera/camera.h"
#include "slam/data/frame.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/geometry/so3.h"
#include "slam/match/line_projection_matcher.h"

namespace lcv::slam::testing {

struct LineSceneOptions {
  CameraModel model = CameraModel::kPerspective;
  int cols = 640, rows = 360;
  int num_lines = 1500;
  double in_view_fraction = 0.75;  // hidden points inside the client image; the rest anywhere
  double min_depth_m = 1.5, max_depth_m = 12.0;
  double detection_rate = 0.7;  // in-view hidden points that become keypoints
  int clutter = 300;            // keypoints of no hidden point
  double pixel_sigma = 0.7;
  int prototypes = 64;
  double prototype_flip_probability = 0.2;  // point descriptor vs its prototype
  // Keypoint descriptor vs its point's descriptor: uniform in this range per keypoint (true ORB
  // matches across nearby views are mostly 10-50 bits apart).
  int min_flipped_bits = 10, max_flipped_bits = 50;
  int num_server_keyframes = 4;
  double server_baseline_m = 0.6;  // server keyframe centres within this of the client's
  double min_distance_m = 0.3, max_distance_m = 30.0;  // LineVisibleInterval bounds
  std::uint64_t seed = 1;
};

struct LineScene {
  std::unique_ptr<Camera> camera;
  Rigid3d cam_from_world;  // the true client pose
  std::vector<Eigen::Vector3d> hidden_points;
  std::vector<double> hidden_s;           // parameter of hidden point j on line j
  std::vector<LineMatchCandidate> lines;  // line j hides point j; id = kFirstLineId + j
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  std::vector<int> point_of_keypoint;  // the hidden point, -1 for clutter
  static constexpr Id kFirstLineId = 100000;
};

inline void FlipRandomBits(int count, std::mt19937_64* rng, OrbDescriptor* d) {
  std::uniform_int_distribution<int> bit(0, 255);
  for (int b = 0; b < count; ++b) {
    const int k = bit(*rng);
    (*d)[k / 8] ^= static_cast<std::uint8_t>(1u << (k % 8));
  }
}

// Octaves as an ORB pyramid yields them: most keypoints at level 0.
inline int RandomOctave(std::mt19937_64* rng) {
  std::geometric_distribution<int> levels(0.45);
  return std::min(levels(*rng), 7);
}

// A pose at centre looking along forward (camera z), with a random roll.
inline Rigid3d LookingAlong(const Eigen::Vector3d& center, const Eigen::Vector3d& forward,
                            std::mt19937_64* rng) {
  const Eigen::Vector3d z = forward.normalized();
  Eigen::Vector3d helper =
      std::abs(z.y()) < 0.9 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
  Eigen::Vector3d x = helper.cross(z).normalized();
  const double roll = std::uniform_real_distribution<double>(-0.3, 0.3)(*rng);
  x = Eigen::AngleAxisd(roll, z) * x;
  Eigen::Matrix3d world_from_cam_rotation;
  world_from_cam_rotation << x, z.cross(x), z;
  const Rigid3d world_from_cam(Eigen::Quaterniond(world_from_cam_rotation), center);
  return world_from_cam.Inverse();
}

inline LineScene MakeLineScene(const LineSceneOptions& o) {
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  LineScene scene;
  scene.camera = MakeCamera(render::SynthCamera(o.model, o.cols, o.rows));
  const Camera& camera = *scene.camera;
  const Eigen::Vector3d client_center(3.0, -1.0, 2.0);
  scene.cam_from_world = LookingAlong(client_center, Eigen::Vector3d(0.3, 0.1, 1.0), &rng);
  const Rigid3d world_from_cam = scene.cam_from_world.Inverse();

  std::vector<OrbDescriptor> prototypes;
  for (int p = 0; p < o.prototypes; ++p) {
    OrbDescriptor d;
    for (auto& byte : d) byte = static_cast<std::uint8_t>(rng() & 0xff);
    prototypes.push_back(d);
  }
  const auto look_alike = [&]() {
    OrbDescriptor d = prototypes[rng() % prototypes.size()];
    for (int k = 0; k < 256; ++k) {
      if (uniform(rng) < o.prototype_flip_probability)
        d[k / 8] ^= static_cast<std::uint8_t>(1u << (k % 8));
    }
    return d;
  };

  std::vector<Rigid3d> server_poses;
  for (int k = 0; k < o.num_server_keyframes; ++k) {
    const Eigen::Vector3d offset = o.server_baseline_m *
                                   UniformUnitVector(uniform(rng), uniform(rng)) *
                                   std::cbrt(uniform(rng));
    const Eigen::Vector3d wobble = 0.08 * UniformUnitVector(uniform(rng), uniform(rng));
    const Rigid3d world_from_server(scene.cam_from_world.rotation.conjugate() * ExpSO3(wobble),
                                    client_center + offset);
    server_poses.push_back(world_from_server.Inverse());
  }

  std::uniform_real_distribution<double> depth(o.min_depth_m, o.max_depth_m);
  std::uniform_real_distribution<double> pixel_noise_unit(0.0, 1.0);
  std::normal_distribution<double> pixel_noise(0.0, o.pixel_sigma);
  while (static_cast<int>(scene.lines.size()) < o.num_lines) {
    Eigen::Vector3d bearing_in_cam;
    if (uniform(rng) < o.in_view_fraction) {
      const Eigen::Vector2d px(uniform(rng) * (o.cols - 1), uniform(rng) * (o.rows - 1));
      const std::optional<Eigen::Vector3d> b = camera.Unproject(px);
      if (!b) continue;
      bearing_in_cam = *b;
    } else {
      bearing_in_cam = UniformUnitVector(uniform(rng), uniform(rng));
    }
    const Eigen::Vector3d point = world_from_cam * (depth(rng) * bearing_in_cam);
    std::vector<Rigid3d> seen_by;
    std::vector<const Camera*> cameras;
    for (const Rigid3d& pose : server_poses) {
      const Eigen::Vector3d p = pose * point;
      const auto px = camera.Project(p);
      if (px && camera.InImage(*px) && p.norm() >= o.min_distance_m) {
        seen_by.push_back(pose);
        cameras.push_back(&camera);
      }
    }
    if (seen_by.empty()) {  // a keyframe of the local window that looks elsewhere
      const Eigen::Vector3d center =
          client_center + o.server_baseline_m * UniformUnitVector(uniform(rng), uniform(rng));
      seen_by.push_back(LookingAlong(center, point - center, &rng));
      cameras.push_back(&camera);
    }
    const Eigen::Vector3d direction = UniformUnitVector(uniform(rng), uniform(rng));
    const Line3d line(point - point.dot(direction) * direction, direction);
    const auto interval =
        LineVisibleInterval(line, seen_by, cameras, o.min_distance_m, o.max_distance_m);
    if (!interval) continue;  // cannot happen for a seen point; kept for safety
    LineMatchCandidate candidate;
    candidate.line_id = LineScene::kFirstLineId + scene.lines.size();
    candidate.line = line;
    candidate.s_min = interval->first;
    candidate.s_max = interval->second;
    candidate.descriptor = look_alike();
    scene.lines.push_back(candidate);
    scene.hidden_points.push_back(point);
    scene.hidden_s.push_back(line.Parameter(point));

    // The client's keypoint of this point.
    const Eigen::Vector3d p_in_cam = scene.cam_from_world * point;
    const auto px = camera.Project(p_in_cam);
    if (!px || uniform(rng) >= o.detection_rate) continue;
    const Eigen::Vector2d noisy = *px + Eigen::Vector2d(pixel_noise(rng), pixel_noise(rng));
    if (!camera.InImage(noisy, 1.0)) continue;
    Keypoint kp;
    kp.x = static_cast<float>(noisy.x());
    kp.y = static_cast<float>(noisy.y());
    kp.angle_deg = 0.f;
    kp.octave = RandomOctave(&rng);
    OrbDescriptor d = candidate.descriptor;
    FlipRandomBits(std::uniform_int_distribution<int>(o.min_flipped_bits, o.max_flipped_bits)(rng),
                   &rng, &d);
    scene.keypoints.push_back(kp);
    scene.descriptors.push_back(d);
    scene.point_of_keypoint.push_back(static_cast<int>(scene.lines.size()) - 1);
  }
  for (int c = 0; c < o.clutter;) {
    const Eigen::Vector2d px(uniform(rng) * (o.cols - 1), uniform(rng) * (o.rows - 1));
    if (!camera.Unproject(px)) continue;  // outside a fisheye's image circle
    Keypoint kp;
    kp.x = static_cast<float>(px.x());
    kp.y = static_cast<float>(px.y());
    kp.angle_deg = 0.f;
    kp.octave = RandomOctave(&rng);
    scene.keypoints.push_back(kp);
    scene.descriptors.push_back(look_alike());
    scene.point_of_keypoint.push_back(-1);
    ++c;
  }
  return scene;
}

// A prepared client frame of the scene (no matches yet).
inline Frame MakeLineSceneFrame(const LineScene& scene) {
  Frame frame;
  frame.id = 1;
  frame.camera = scene.camera.get();
  frame.keypoints = scene.keypoints;
  frame.descriptors = scene.descriptors;
  frame.cam_from_world = scene.cam_from_world;
  frame.has_pose = true;
  PrepareFrame(&frame);
  return frame;
}

struct LineMatchScore {
  int correct = 0;
  int wrong = 0;
  int findable = 0;  // keypoints of hidden points (each has its line among the candidates)
  double Recall() const { return findable > 0 ? double(correct) / findable : 0.0; }
  double Precision() const {
    return correct + wrong > 0 ? double(correct) / (correct + wrong) : 1.0;
  }
};

// Scores frame.landmark_ids against the scene's answer (keypoints whose id is not a line of
// the scene are ignored).
inline LineMatchScore ScoreLineMatches(const LineScene& scene, const Frame& frame) {
  LineMatchScore score;
  for (int i = 0; i < frame.num_keypoints(); ++i) {
    const int point = scene.point_of_keypoint[i];
    if (point >= 0) ++score.findable;
    const Id id = frame.landmark_ids[i];
    if (id < LineScene::kFirstLineId || id >= LineScene::kFirstLineId + scene.lines.size())
      continue;
    (static_cast<int>(id - LineScene::kFirstLineId) == point ? score.correct : score.wrong)++;
  }
  return score;
}

}  // namespace lcv::slam::testing
