#pragma once
// The one map model of the project (paper Sec. 3.1): client keyframes P_kc with their keypoints,
// point landmarks X, line landmarks L (with the restored point X' where a client restored one),
// and server keyframes P_ks, which carry only a pose and the ids of the lines they see.
//
// State only (STYLE.md 1): no file formats here (mapping/io), no locking. Entities refer to each
// other by id. Containers are ordered by id so that iteration, and so every algorithm and file
// written from a map, is deterministic.
//
// Invariants (checked by mapping/io's reader, relied upon everywhere else):
// - every id referenced exists (cameras, keyframes, lines, server keyframes); loop edges join two
//   different client keyframes;
// - an Observation's keypoint_index is < the keyframe's keypoint count;
// - Keyframe::descriptors is empty or as long as keypoints;
// - line directions have unit norm, information matrices are symmetric PSD with the direction in
//   their null space; all numbers are finite.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

// A 2D observation: keypoint keypoint_index of client keyframe keyframe_id.
struct Observation {
  Id keyframe_id = kInvalidId;
  std::uint32_t keypoint_index = 0;
};

// A client keyframe (P_kc).
struct Keyframe {
  Id id = kInvalidId;
  Id camera_id = kInvalidId;
  double timestamp = 0.0;  // seconds
  Rigid3d cam_from_world;
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;  // empty, or one per keypoint
};

// A 3D point X reconstructed from 2D observations.
struct PointLandmark {
  Id id = kInvalidId;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world frame, map units
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // Sigma_X, map units^2
  std::optional<OrbDescriptor> descriptor;  // representative descriptor, when known
  std::vector<Observation> observations;
};

// A 3D line L = {p_L, d_L} of a line cloud with its information matrix Omega_L (eq. 1).
struct LineLandmark {
  Id id = kInvalidId;
  Line3d line;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();  // Omega_L, rank 2, d in null space
  std::optional<OrbDescriptor> descriptor;
  std::vector<Id> server_keyframe_ids;  // the server keyframes that see it
  // X': the point a client restored on (near) this line from its own observations, with those
  // observations x'. Never present in a published line cloud.
  std::optional<Eigen::Vector3d> restored_point;
  std::vector<Observation> observations;
};

// A server keyframe (P_ks): pose and visible lines, no keypoints (they would reveal the points).
struct ServerKeyframe {
  Id id = kInvalidId;
  Id camera_id = kInvalidId;
  double timestamp = 0.0;
  Rigid3d cam_from_world;
  std::vector<Id> line_ids;
};

struct Map {
  std::map<Id, CameraParams> cameras;
  std::map<Id, Keyframe> keyframes;
  std::map<Id, PointLandmark> points;
  std::map<Id, LineLandmark> lines;
  std::map<Id, ServerKeyframe> server_keyframes;
  // Loop edges of the client keyframes' essential graph (pairs of keyframe ids joined by loop
  // closing), kept so that a reloaded map still knows its loops (and renders show them).
  std::vector<std::pair<Id, Id>> loop_edges;
  // Free-form provenance ("lcv map import --colmap ...", "lcv slam ..."), kept in files.
  std::string description;

  // One more than the largest id in use in any container: ids are unique map-wide, so a point
  // converted to a line keeps its id and a reference map can be matched to a line cloud by id.
  Id NextFreeId() const;
};

// True for a line cloud fit for publishing: no client keyframes (no keypoint coordinates), no
// points, no restored points and no client observations on lines.
bool IsPublishedLineCloud(const Map& map);

}  // namespace lcv::slam
