#pragma once
// Descriptor matching through the direct index (ORB-SLAM's SearchByBoW without the rotation
// histogram, which needs keypoint angles and belongs to slam/match): only features that passed
// the same vocabulary node are compared, which cuts the brute-force cost by ~branching^level.
//
// For each feature of A, the nearest feature of B in the same node (Hamming distance); kept when
// distance <= max_distance and distance < ratio * second-nearest (Lowe's test; a single
// candidate passes it). A feature of B claimed by several features of A keeps the nearest (ties:
// the smaller index of A). Both direct indices must come from the same vocabulary and level.

#include <utility>
#include <vector>

#include "slam/bow/bow_vector.h"
#include "slam/feature/keypoint.h"

namespace lcv::slam {

struct DirectIndexMatchOptions {
  int max_distance = 50;  // Hamming bits (ORB-SLAM's TH_LOW)
  float ratio = 0.75f;    // nearest / second nearest, in (0, 1]
};

struct DescriptorMatch {
  int index_a = -1;
  int index_b = -1;
  int distance = 0;  // Hamming bits
};

// Clears and fills *matches, ordered by index_a. Returns the number of matches.
int MatchByDirectIndex(const DirectIndex& index_a, const std::vector<OrbDescriptor>& descriptors_a,
                       const DirectIndex& index_b, const std::vector<OrbDescriptor>& descriptors_b,
                       const DirectIndexMatchOptions& options, std::vector<DescriptorMatch>* matches);

}  // namespace lcv::slam
