#pragma once
// A synthetic client local map and a server line cloud of the same place for the line-cloud
// registration tests and bench (header-only, seeded).
//
// The server frame is the ground truth (metres). Scene points lie in the current keyframe's
// (ckf) view, 4-12 m in front of it; the ckf sits at the origin looking along +z, the other
// views are 0.4 m apart along x with a slight turn. The client sees the same scene in its own
// frame and scale: client = server_from_client_true^-1 * server, with per-point noise of
// depth_noise_ratio x range along the ckf's ray and pixel_noise_px / focal x range across it,
// and noisy pixel observations in every view that images the point.
//
// Server side: a line through every one of the first num_lines_of_points scene points (random
// direction, anchor slid along it, small position noise), num_other_lines lines of other points
// (server only), server points (X' restored earlier) for the last num_server_points scene points
// plus num_other_server_points others. Descriptors: each scene point has a random 256-bit one;
// client points, lines and server points carry it with descriptor_flip_bits flipped. A fraction
// wrong_match_ratio of the client points instead carry (a noisy copy of) the descriptor of
// another point's line (or server point, when it has no line): wrong matches that pass every
// descriptor test.

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/sim3.h"
#include "slam/geometry/so3.h"
#include "slam/module/line_cloud_registration.h"

namespace lcv::slam::testing {

struct RegistrationSceneOptions {
  int num_points = 300;
  int num_lines_of_points = 300;  // the first ones
  int num_server_points = 0;      // the last ones
  int num_other_lines = 300;
  int num_other_server_points = 0;
  int num_views = 4;
  double pixel_noise_px = 0.7;
  double depth_noise_ratio = 0.01;
  double server_noise_m = 0.01;
  double line_sigma_m = 0.03;  // of the server point a line replaces (Omega_L)
  int descriptor_flip_bits = 6;
  double wrong_match_ratio = 0.0;
  double rotation_deg = 40.0;
  double scale = 2.5;      // server units per client unit
  bool collinear = false;  // all scene points on one 3D segment (a degenerate scene)
  std::uint64_t seed = 1;
};

struct RegistrationScene {
  Sim3d server_from_client_true;
  std::vector<Eigen::Vector3d> true_points;  // server frame, one per scene point
  std::vector<Rigid3d> true_cam_from_server;
  std::vector<RegistrationView> views;
  std::vector<RegistrationPoint> points;  // landmark_id = scene point index
  std::vector<RegistrationLine> lines;    // line_id = scene point index; others >= num_points
  std::vector<RegistrationServerPoint> server_points;  // id as lines
  std::vector<char> wrong_descriptor;                  // per client point
};

inline OrbDescriptor NoisyCopy(const OrbDescriptor& d, int flips, std::mt19937_64* rng) {
  OrbDescriptor out = d;
  std::uniform_int_distribution<int> bit(0, 255);
  for (int k = 0; k < flips; ++k) {
    const int b = bit(*rng);
    out[b / 8] ^= static_cast<std::uint8_t>(1u << (b % 8));
  }
  return out;
}

// camera must outlive the scene's views.
inline RegistrationScene MakeRegistrationScene(const Camera& camera,
                                               const RegistrationSceneOptions& o) {
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto random_descriptor = [&] {
    OrbDescriptor d;
    for (auto& byte : d) byte = static_cast<std::uint8_t>(rng() & 0xff);
    return d;
  };
  RegistrationScene scene;
  const Eigen::Vector3d axis = UniformUnitVector(unit(rng), unit(rng));
  scene.server_from_client_true =
      Sim3d(o.scale, Eigen::Quaterniond(ExpSO3(o.rotation_deg * M_PI / 180.0 * axis)),
            Eigen::Vector3d(3.0 * normal(rng), 3.0 * normal(rng), normal(rng)));
  const Sim3d client_from_server = scene.server_from_client_true.Inverse();

  for (int v = 0; v < o.num_views; ++v) {
    const double x = 0.4 * v - 0.2 * (o.num_views - 1);
    const Rigid3d server_from_cam(Eigen::Quaterniond(ExpSO3(Eigen::Vector3d(0.0, 0.02 * v, 0.0))),
                                  Eigen::Vector3d(v == 0 ? 0.0 : x, 0.05 * v, 0.0));
    scene.true_cam_from_server.push_back(server_from_cam.Inverse());
  }
  // The ckf at the origin: shift the others so that views[0] is the reference.
  const double focal_px = camera.model() == CameraModel::kEquirectangular
                              ? camera.cols() / (2.0 * M_PI)
                              : camera.params().fx;
  const int num_scene = o.num_points + std::max(o.num_other_lines, o.num_other_server_points);
  std::vector<OrbDescriptor> scene_descriptors;
  for (int j = 0; j < num_scene; ++j) {
    // A bearing inside ~70% of a 640x360 pinhole's field of view, 4-12 m away.
    const Eigen::Vector3d bearing =
        Eigen::Vector3d(0.45 * (2.0 * unit(rng) - 1.0), 0.25 * (2.0 * unit(rng) - 1.0), 1.0)
            .normalized();
    scene.true_points.push_back(o.collinear ? Eigen::Vector3d(-2.0, 0.5, 6.0) +
                                                  unit(rng) * Eigen::Vector3d(4.0, -1.0, 4.0)
                                            : Eigen::Vector3d((4.0 + 8.0 * unit(rng)) * bearing));
    scene_descriptors.push_back(random_descriptor());
  }

  for (int v = 0; v < o.num_views; ++v) {
    RegistrationView view;
    view.keyframe_id = 100 + v;
    view.cam_from_world = TransformPose(client_from_server, scene.true_cam_from_server[v]);
    view.camera = &camera;
    scene.views.push_back(view);
  }

  // Client points.
  for (int j = 0; j < o.num_points; ++j) {
    const Eigen::Vector3d& p = scene.true_points[j];
    const double range = p.norm();
    const Eigen::Vector3d ray = p / range;
    const Eigen::Vector3d lateral(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d noisy =
        p + o.depth_noise_ratio * range * normal(rng) * ray +
        (o.pixel_noise_px / focal_px) * range * (lateral - lateral.dot(ray) * ray);
    RegistrationPoint point;
    point.landmark_id = j;
    point.position = client_from_server * noisy;
    point.descriptor = NoisyCopy(scene_descriptors[j], o.descriptor_flip_bits, &rng);
    for (int v = 0; v < o.num_views; ++v) {
      const auto px = camera.Project(scene.true_cam_from_server[v] * p);
      if (!px || !camera.InImage(*px)) continue;
      RegistrationObservation obs;
      obs.view = v;
      obs.observed_px = *px + o.pixel_noise_px * Eigen::Vector2d(normal(rng), normal(rng));
      point.observations.push_back(obs);
    }
    scene.points.push_back(point);
  }
  scene.wrong_descriptor.assign(o.num_points, 0);

  // Server lines and points.
  const Eigen::Matrix3d covariance = o.line_sigma_m * o.line_sigma_m * Eigen::Matrix3d::Identity();
  auto add_line = [&](int j) {
    const Eigen::Vector3d d = UniformUnitVector(unit(rng), unit(rng));
    const Eigen::Vector3d hidden =
        scene.true_points[j] +
        o.server_noise_m * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    RegistrationLine line;
    line.line_id = j;
    line.line = Line3d(hidden + 2.0 * (2.0 * unit(rng) - 1.0) * d, d);
    line.information = LineInformation(d, covariance);
    line.descriptor = NoisyCopy(scene_descriptors[j], o.descriptor_flip_bits, &rng);
    scene.lines.push_back(line);
  };
  auto add_server_point = [&](int j) {
    RegistrationServerPoint sp;
    sp.id = j;
    sp.position = scene.true_points[j] +
                  o.server_noise_m * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    sp.descriptor = NoisyCopy(scene_descriptors[j], o.descriptor_flip_bits, &rng);
    scene.server_points.push_back(sp);
  };
  for (int j = 0; j < o.num_lines_of_points; ++j) add_line(j);
  for (int j = o.num_points - o.num_server_points; j < o.num_points; ++j) add_server_point(j);
  for (int k = 0; k < o.num_other_lines; ++k) add_line(o.num_points + k);
  for (int k = 0; k < o.num_other_server_points; ++k) add_server_point(o.num_points + k);

  // Wrong descriptors: a client point takes the descriptor of another scene point's line or
  // server point (the other points first, each used once).
  const int num_wrong = static_cast<int>(std::lround(o.wrong_match_ratio * o.num_points));
  std::vector<int> order(o.num_points);
  for (int j = 0; j < o.num_points; ++j) order[j] = j;
  std::shuffle(order.begin(), order.end(), rng);
  const int num_decoys = std::max(o.num_other_lines, o.num_other_server_points);
  for (int k = 0; k < num_wrong && k < num_decoys; ++k) {
    const int j = order[k];
    scene.points[j].descriptor =
        NoisyCopy(scene_descriptors[o.num_points + k], o.descriptor_flip_bits, &rng);
    scene.wrong_descriptor[j] = 1;
  }
  return scene;
}

}  // namespace lcv::slam::testing
