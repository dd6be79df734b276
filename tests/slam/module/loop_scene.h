#pragma once
// A synthetic SlamMap of a loop for the loop-closing tests (header-only, seeded).
//
// The camera moves on a circle of radius 4 m around the origin, looking outwards at points on a
// cylinder wall of radius 10 m (heights in [-2, 2] m, random 256-bit descriptors). Keyframe k is
// at azimuth k * step (+ a half step on the second lap, so no pose repeats exactly); with
// num_keyframes > 360 / step the last keyframes revisit the first ones' part of the wall.
//
// Landmarks are made as a SLAM system would: a point seen again within max_gap keyframes keeps
// its landmark; a point seen again after a longer gap (the revisit) gets a NEW landmark, a
// duplicate of the first lap's. Drift: keyframe k's estimated pose and the landmarks it creates
// are expressed in the world est = D_k * world_true, D_k a similarity (rotation about the
// vertical axis and scale about the origin) that is the identity up to drift_start, grows
// linearly until drift_end and stays at drift_final after it. Landmark positions get
// position_noise_m of isotropic noise.

#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <algorithm>
#include <vector>

#include "slam/bow/bow_database.h"
#include "slam/bow/vocabulary.h"
#include "slam/data/frame.h"
#include "slam/data/slam_map.h"
#include "slam/geometry/sim3.h"
#include "slam/geometry/so3.h"
#include "slam/solve/umeyama.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam::testing {

struct LoopSceneOptions {
  int num_points = 3000;
  int num_keyframes = 48;
  double step_deg = 9.0;
  int max_gap = 3;
  int drift_start = 16;
  int drift_end = 32;
  double drift_yaw_deg = 6.0;
  double drift_scale = 1.12;
  double position_noise_m = 0.0;
  std::uint64_t seed = 7;
  CameraParams camera = SyntheticPinhole();
};

// A fisheye (about 120 degrees across) and an equirectangular camera for the same scene.
inline CameraParams RingFisheye() {
  CameraParams params = SyntheticPinhole();
  params.model = CameraModel::kFisheye;
  params.fx = params.fy = 230.0;
  return params;
}
inline CameraParams RingEquirectangular() {
  CameraParams params;
  params.name = "synthetic equirectangular";
  params.model = CameraModel::kEquirectangular;
  params.cols = 1280;
  params.rows = 640;
  return params;
}

struct LoopScene {
  std::unique_ptr<Camera> camera;
  SyntheticScene scene;
  std::vector<Rigid3d> true_cam_from_world;  // per keyframe, in order
  std::vector<Sim3d> drift;                  // world_est_from_world_true per keyframe
  std::vector<Id> keyframe_ids;
  std::map<Id, int> point_of_landmark;       // scene point index of each landmark
  std::vector<std::vector<int>> point_of_keypoint;  // per keyframe: scene point or -1 (clutter)
  Vocabulary vocabulary;
  BowDatabase database;
  SlamMap map;
};

inline Rigid3d RingPose(double azimuth_rad, double height_m) {
  const Eigen::Vector3d z(std::cos(azimuth_rad), std::sin(azimuth_rad), 0.0);
  const Eigen::Vector3d y(0.0, 0.0, -1.0);
  const Eigen::Vector3d x = y.cross(z);
  Eigen::Matrix3d world_from_cam_rotation;
  world_from_cam_rotation << x, y, z;
  const Eigen::Vector3d center(4.0 * std::cos(azimuth_rad), 4.0 * std::sin(azimuth_rad), height_m);
  return Rigid3d(Eigen::Quaterniond(world_from_cam_rotation), center).Inverse();
}

inline Sim3d DriftAt(const LoopSceneOptions& o, int k) {
  double f = 0.0;
  if (k >= o.drift_end) {
    f = 1.0;
  } else if (k > o.drift_start) {
    f = static_cast<double>(k - o.drift_start) / (o.drift_end - o.drift_start);
  }
  const double yaw = f * o.drift_yaw_deg * M_PI / 180.0;
  return Sim3d(std::pow(o.drift_scale, f), ExpSO3(Eigen::Vector3d(0.0, 0.0, yaw)),
               Eigen::Vector3d::Zero());
}

// Builds the scene, trains a small vocabulary on its keyframes and fills map and database.
inline std::unique_ptr<LoopScene> MakeLoopScene(const LoopSceneOptions& o) {
  auto s = std::make_unique<LoopScene>();
  s->camera = MakeCamera(o.camera);
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> azimuth(0.0, 2.0 * M_PI), height(-2.0, 2.0);
  for (int j = 0; j < o.num_points; ++j) {
    const double a = azimuth(rng);
    s->scene.points_in_world.emplace_back(10.0 * std::cos(a), 10.0 * std::sin(a), height(rng));
    s->scene.descriptors.push_back(RandomDescriptor(&rng));
  }
  ObservationNoise noise;
  noise.clutter = 30;
  std::vector<SyntheticFrame> observed;
  const double lap = 360.0 / o.step_deg;
  for (int k = 0; k < o.num_keyframes; ++k) {
    const double az = (k * o.step_deg + (k >= lap ? 0.5 * o.step_deg : 0.0)) * M_PI / 180.0;
    s->true_cam_from_world.push_back(RingPose(az, 0.2 * std::sin(0.7 * k)));
    s->drift.push_back(DriftAt(o, k));
    observed.push_back(ObserveScene(s->scene, *s->camera, s->true_cam_from_world[k], noise, &rng));
  }
  std::vector<std::vector<OrbDescriptor>> training;
  for (const SyntheticFrame& f : observed) {
    training.push_back(f.descriptors);
    s->point_of_keypoint.push_back(f.point_index);
  }
  VocabularyOptions vocabulary_options;
  vocabulary_options.branching = 10;
  vocabulary_options.depth = 4;
  vocabulary_options.max_iterations = 4;
  s->vocabulary = Vocabulary::Train(training, vocabulary_options);

  std::normal_distribution<double> position_noise(0.0, o.position_noise_m);
  std::map<int, std::pair<Id, int>> instance;  // scene point -> (landmark, last keyframe index)
  for (int k = 0; k < o.num_keyframes; ++k) {
    Frame frame;
    frame.id = k;
    frame.timestamp = k;
    frame.camera = s->camera.get();
    frame.keypoints = observed[k].keypoints;
    frame.descriptors = observed[k].descriptors;
    frame.cam_from_world = TransformPose(s->drift[k], s->true_cam_from_world[k]);
    PrepareFrame(&frame);
    s->vocabulary.Transform(frame.descriptors, &frame.bow, &frame.direct_index, 2);
    const Id kf = s->map.AddKeyframe(frame).id;
    s->keyframe_ids.push_back(kf);
    s->database.Add(kf, frame.bow);
    for (size_t i = 0; i < observed[k].point_index.size(); ++i) {
      const int j = observed[k].point_index[i];
      if (j < 0) continue;
      auto it = instance.find(j);
      if (it == instance.end() || k - it->second.second > o.max_gap) {
        Eigen::Vector3d p = s->drift[k] * s->scene.points_in_world[j];
        if (o.position_noise_m > 0.0) {
          p += Eigen::Vector3d(position_noise(rng), position_noise(rng), position_noise(rng));
        }
        const Id id = s->map.AddLandmark(p, kf).id;
        s->point_of_landmark[id] = j;
        instance[j] = {id, k};
        it = instance.find(j);
      }
      s->map.AddObservation(it->second.first, kf, static_cast<int>(i));
      it->second.second = k;
    }
  }
  std::vector<Id> landmark_ids;
  for (const auto& [id, landmark] : s->map.landmarks()) landmark_ids.push_back(id);
  for (const Id id : landmark_ids) {
    if (s->map.landmarks().at(id).NumObservations() < 2) {
      s->map.EraseLandmark(id);
      s->point_of_landmark.erase(id);
    } else {
      s->map.UpdateLandmarkGeometry(id);
    }
  }
  for (const Id id : s->keyframe_ids) s->map.UpdateCovisibility(id);
  return s;
}

// The first broken invariant of slam/data/slam_map.h found, or empty: keypoint <-> landmark
// links agree both ways, one observation per keyframe per landmark, covisibility is symmetric,
// spanning-tree links exist and agree, positions are finite.
inline std::string MapProblem(const SlamMap& map) {
  for (const auto& [id, kf] : map.keyframes()) {
    for (size_t i = 0; i < kf.landmark_ids.size(); ++i) {
      const Id landmark_id = kf.landmark_ids[i];
      if (landmark_id == kInvalidId) continue;
      const SlamLandmark* landmark = map.FindLandmark(landmark_id);
      if (landmark == nullptr) return "keyframe " + std::to_string(id) + " links a missing landmark";
      bool found = false;
      for (const Observation& o : landmark->observations) {
        found |= o.keyframe_id == id && o.keypoint_index == i;
      }
      if (!found) return "landmark " + std::to_string(landmark_id) + " lacks an observation";
    }
    if (!kf.cam_from_world.translation.allFinite()) return "non-finite keyframe pose";
    for (const auto& [other, weight] : kf.covisibility_weights) {
      const SlamKeyframe* o = map.FindKeyframe(other);
      if (o == nullptr || !o->covisibility_weights.count(id)) return "asymmetric covisibility";
    }
    if (kf.parent_id != kInvalidId) {
      const SlamKeyframe* parent = map.FindKeyframe(kf.parent_id);
      if (parent == nullptr) return "missing parent";
      if (std::find(parent->child_ids.begin(), parent->child_ids.end(), id) ==
          parent->child_ids.end()) {
        return "parent does not list its child";
      }
    } else if (id != map.first_keyframe_id()) {
      return "keyframe " + std::to_string(id) + " without parent";
    }
  }
  for (const auto& [id, landmark] : map.landmarks()) {
    if (!landmark.position_in_world.allFinite()) return "non-finite landmark";
    std::set<Id> seen_by;
    for (const Observation& o : landmark.observations) {
      const SlamKeyframe* kf = map.FindKeyframe(o.keyframe_id);
      if (kf == nullptr) return "observation by a missing keyframe";
      if (kf->landmark_ids[o.keypoint_index] != id) return "observation not linked back";
      if (!seen_by.insert(o.keyframe_id).second) return "two observations by one keyframe";
    }
  }
  return "";
}

// RMS distance of the keyframe centres to the truth after the best similarity alignment
// (Umeyama), over the given keyframe indices of the scene.
inline double AlignedTrajectoryRmse(const LoopScene& s) {
  std::vector<Eigen::Vector3d> estimated, truth;
  for (size_t k = 0; k < s.keyframe_ids.size(); ++k) {
    const SlamKeyframe* kf = s.map.FindKeyframe(s.keyframe_ids[k]);
    if (kf == nullptr) continue;
    estimated.push_back(kf->Center());
    truth.push_back(s.true_cam_from_world[k].Center());
  }
  Sim3d truth_from_estimated;
  if (!AlignUmeyama(estimated, truth, true, &truth_from_estimated)) return -1.0;
  double sum = 0.0;
  for (size_t k = 0; k < estimated.size(); ++k) {
    sum += (truth_from_estimated * estimated[k] - truth[k]).squaredNorm();
  }
  return std::sqrt(sum / estimated.size());
}

}  // namespace lcv::slam::testing
