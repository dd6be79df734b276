#pragma once
// Keypoints of two frames paired by descriptor alone, without any pose or window (the 2D-2D
// matches of tracking's two-view step, slam/tracking.h): for views tens of degrees apart, where
// the area matcher's window (area_matcher.h) and a pose prediction's (projection_matcher.h) both
// miss, and without a vocabulary (bow_matcher.h).
//
// A pair (i in a, j in b) is kept when j is i's nearest keypoint of b and i is j's nearest of
// a (mutual), within max_octave_difference octaves, at Hamming distance <= max_hamming_distance,
// i's nearest is clearly nearer than its second (best < ratio * second), both bearings are valid
// (the camera could unproject them), and the rotation between the two keypoint angles is in one
// of the orientation histogram's dominant bins (projection_matcher.h's DominantRotationBins).
// Brute force: O(|a| |b|) descriptor comparisons (~1 ms per 1000 x 1000 keypoints); meant for
// a frame that tracking would otherwise lose, not for every frame.

#include <utility>
#include <vector>

#include "slam/data/frame.h"

namespace lcv::slam {

struct FrameMatchOptions {
  // Looser than ORB-SLAM's TH_LOW (50) and its 0.6-0.8 ratios: the pairs go to a RANSAC on the
  // epipolar constraint, which removes the wrong ones; across a sharp turn the strict values
  // left 43 pairs where the looser ones gave 93 (synthetic loop, perspective, frame 73).
  int max_hamming_distance = 64;
  float ratio = 0.9f;
  int max_octave_difference = 2;
  bool check_orientation = true;
  int orientation_bins = 30;
};

// Pairs (keypoint index in a, keypoint index in b), sorted by the index in a. Requires prepared
// frames (descriptors, bearings: PrepareFrame).
std::vector<std::pair<int, int>> MatchFramesByDescriptor(const Frame& a, const Frame& b,
                                                         const FrameMatchOptions& options = {});

}  // namespace lcv::slam
