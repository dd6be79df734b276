#pragma once
// A server line cloud on the ring scene of loop_scene.h (tests of the LC-VSLAM client's loop
// closing and bundle adjustments): the scene's points, hidden in lines of random direction, seen
// by server keyframes at true poses; the client's landmarks restored on them as X'.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "slam/geometry/line3.h"
#include "tests/slam/module/loop_scene.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam::testing {

inline constexpr Id kFirstLineId = 5000000;
inline constexpr Id kFirstServerKeyframeId = 6000000;

inline Eigen::Vector3d RandomDirection(std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  return Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng)).normalized();
}

// One line per scene point (through it, random direction, the point's descriptor), seen by
// the server keyframe at the true pose of ring keyframe server_poses[k] that sees the point
// (the first one that does). Returns the line id of each scene point (-1: none).
inline std::vector<Id> AddLineCloud(const std::vector<int>& server_poses, std::uint64_t seed,
                             LoopScene* s) {
  std::mt19937_64 rng(seed);
  const CameraParams params = testing::SyntheticPinhole();
  s->map.AddServerCamera(1, params);
  std::vector<Id> line_of_point(s->scene.points_in_world.size(), kInvalidId);
  std::vector<SlamServerKeyframe*> server;
  for (size_t k = 0; k < server_poses.size(); ++k) {
    SlamServerKeyframe& kf = s->map.AddServerKeyframeWithId(kFirstServerKeyframeId + k);
    kf.camera_id = 1;
    kf.cam_from_world = s->true_cam_from_world[server_poses[k]];
    kf.published_cam_from_world = kf.cam_from_world;  // as slam_map_import does
    server.push_back(&kf);
  }
  Id next = kFirstLineId;
  for (size_t j = 0; j < s->scene.points_in_world.size(); ++j) {
    const Eigen::Vector3d& p = s->scene.points_in_world[j];
    int seen_by = -1;
    for (size_t k = 0; k < server.size() && seen_by < 0; ++k) {
      const Eigen::Vector3d in_cam = server[k]->cam_from_world * p;
      const auto px = s->camera->Project(in_cam);
      if (px && in_cam.z() > 0.0) seen_by = static_cast<int>(k);
    }
    if (seen_by < 0) continue;
    SlamLine& line = s->map.AddLineWithId(next);
    const Eigen::Vector3d d = RandomDirection(&rng);
    std::uniform_real_distribution<double> offset(-2.0, 2.0);
    line.line = Line3d(p + offset(rng) * d, d);
    line.published_line = line.line;
    line.reference_line = line.line;
    line.information = LineInformation(d, 0.01 * 0.01 * Eigen::Matrix3d::Identity());
    line.sqrt_information = SqrtInformation(line.information);
    line.descriptor = s->scene.descriptors[j];
    line.server_keyframe_ids.push_back(server[seen_by]->id);
    server[seen_by]->line_ids.push_back(next);
    line_of_point[j] = next++;
  }
  return line_of_point;
}

// Restores the landmarks first seen by the ring keyframes [0, last] on their lines and marks
// the segment registered: the client was registered in the line cloud there.
inline int RestoreOnLines(const std::vector<Id>& line_of_point, int last, LoopScene* s) {
  int restored = 0;
  for (int k = 0; k <= last; ++k) {
    for (const Id landmark_id : s->map.FindKeyframe(s->keyframe_ids[k])->landmark_ids) {
      const SlamLandmark* landmark = s->map.FindLandmark(landmark_id);
      if (landmark == nullptr || landmark->IsRestored()) continue;
      const Id line_id = line_of_point[s->point_of_landmark.at(landmark_id)];
      if (line_id == kInvalidId || s->map.FindLine(line_id)->restored_landmark_id != kInvalidId) {
        continue;
      }
      s->map.FindLandmark(landmark_id)->position_in_world =
          s->map.FindLine(line_id)->line.Project(landmark->position_in_world);
      s->map.RestoreOnLine(landmark_id, line_id);
      ++restored;
    }
  }
  s->map.SetRegisteredSegment(s->map.active_segment());
  return restored;
}

// RMS distance of keyframe centres to the truth, no alignment (the server's frame is the
// truth's), over ring keyframes [first, last].
inline double CentreRmse(const LoopScene& s, int first, int last) {
  double sum = 0.0;
  int n = 0;
  for (int k = first; k <= last; ++k) {
    const SlamKeyframe* kf = s.map.FindKeyframe(s.keyframe_ids[k]);
    if (kf == nullptr) continue;
    sum += (kf->Center() - s.true_cam_from_world[k].Center()).squaredNorm();
    ++n;
  }
  return std::sqrt(sum / std::max(1, n));
}

}  // namespace lcv::slam::testing
