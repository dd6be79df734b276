#pragma once
// Guided matching of map landmarks into a keyframe seen from a similarity pose: ORB-SLAM2's
// ORBmatcher::SearchByProjection(KeyFrame*, cv::Mat Scw, ...) and Fuse(KeyFrame*, cv::Mat Scw,
// ...), used by loop detection (landmarks of the matched side projected into the query with the
// loop's Sim(3)) and loop correction (fusion into the corrected keyframes).
//
// A landmark is projected with cam_from_world (a similarity: x_cam = s R X + t; the projection
// only depends on the direction, so the scale is irrelevant there). It is skipped when it is
// already observed by the keyframe, lies behind or outside the image, its distance to the camera
// centre (world units, centre = cam_from_world^-1 * 0) is outside [0.8 min_distance,
// 1.2 max_distance], or it is seen more than max_view_angle_deg away from its mean viewing
// direction. Otherwise the keyframe's keypoints within radius_factor * Scale(predicted octave)
// pixels and of octave predicted - 1 or predicted (ORB-SLAM's band) are compared by Hamming
// distance; the nearest one within max_hamming_distance is the match. A keypoint claimed by
// several landmarks keeps the nearest descriptor (ties: the smaller landmark id).
//
// Thread safety: reads the map only; the caller keeps it from changing during the call.

#include <vector>

#include "slam/data/slam_map.h"
#include "slam/geometry/sim3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct KeyframeProjectionOptions {
  float radius_factor = 10.f;      // window half-size in units of the octave's scale (px)
  int max_hamming_distance = 50;   // ORB-SLAM's TH_LOW
  double max_view_angle_deg = 60.0;
};

struct KeyframeProjectionMatch {
  int keypoint_index = -1;
  Id landmark_id = kInvalidId;
  int distance = 0;  // Hamming bits
};

// Matches by keypoint index (ascending). keypoint_blocked, when given, has one entry per keypoint
// of the keyframe; keypoints with a nonzero entry are not matched (already matched elsewhere).
// Landmark ids that do not exist are skipped.
std::vector<KeyframeProjectionMatch> MatchLandmarksIntoKeyframe(
    const SlamMap& map, const SlamKeyframe& keyframe, const Sim3d& cam_from_world,
    const std::vector<Id>& landmark_ids, const KeyframeProjectionOptions& options,
    const std::vector<char>* keypoint_blocked = nullptr);

}  // namespace lcv::slam
