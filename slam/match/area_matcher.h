#pragma once
// Matching for monocular initialization (ORB-SLAM's SearchForInitialization): each keypoint of
// the reference frame is searched for in a square window of the current frame around where it
// was last found (its own position at first), by Hamming distance with a ratio test, a
// one-to-one check and the orientation-consistency histogram.

#include <vector>

#include <Eigen/Core>

#include "slam/data/frame.h"

namespace lcv::slam {

struct AreaMatchOptions {
  float window_px = 100.f;          // half-size of the search window
  int max_hamming_distance = 50;    // ORB-SLAM's TH_LOW
  float ratio = 0.9f;               // best < ratio * second best
  bool check_orientation = true;
  int orientation_bins = 30;
  int max_octave = 7;               // only keypoints of octaves <= this take part (both frames)
};

// matches[i] is the index in `current` of reference keypoint i's match, or -1.
// predicted_px[i] is where reference keypoint i is expected in current (updated with the match
// positions on return, so that tracking the reference over frames follows slow motion). When
// empty on input it is initialised with the reference keypoint positions.
// Returns the number of matches.
int MatchInWindow(const Frame& reference, const Frame& current, const AreaMatchOptions& options,
                  std::vector<Eigen::Vector2f>* predicted_px, std::vector<int>* matches);

}  // namespace lcv::slam
