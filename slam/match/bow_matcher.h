#pragma once
// Matching a keyframe's landmarks into a frame through the vocabulary's direct index: ORB-SLAM2's
// ORBmatcher::SearchByBoW(KeyFrame*, Frame&, ...), used by relocalization.
//
// Only keyframe keypoints that hold a landmark take part. Each is compared with the frame's
// keypoints that passed the same vocabulary node (MatchByDirectIndex: Hamming distance <=
// max_distance, Lowe's ratio against the second nearest, a frame keypoint claimed twice keeps
// the nearest). Then, when check_orientation, the rotation from the keyframe keypoint's angle to
// the frame keypoint's angle is histogrammed and only matches in the three dominant bins stay
// (DominantRotationBins); matches where either angle is unknown (< 0) are not binned and stay.
//
// Both direct indices must be built with the same vocabulary at the same level
// (kDirectIndexLevel). Thread safety: reads its inputs only.

#include <vector>

#include "slam/data/frame.h"
#include "slam/data/slam_map.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct BowMatchOptions {
  int max_distance = 50;    // Hamming bits (ORB-SLAM's TH_LOW)
  float ratio = 0.75f;      // nearest / second nearest, in (0, 1]
  bool check_orientation = true;
  int orientation_bins = 30;
};

struct BowLandmarkMatch {
  int frame_keypoint = -1;
  Id landmark_id = kInvalidId;
  int distance = 0;  // Hamming bits
};

// Clears and fills *matches (ascending frame_keypoint). Returns their number.
int MatchKeyframeLandmarksByBow(const SlamKeyframe& keyframe, const Frame& frame,
                                const BowMatchOptions& options,
                                std::vector<BowLandmarkMatch>* matches);

}  // namespace lcv::slam
