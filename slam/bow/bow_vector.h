#pragma once
// Bag-of-words vectors and direct indices (DBoW2, Galvez-Lopez and Tardos 2012), plain data.
//
// A BowVector is sparse: (word, weight) entries sorted by word id, each word at most once,
// weights > 0 summing to 1 (L1-normalized TF-IDF), or empty for an image without known words.
// A DirectIndex groups the features of one image by the vocabulary node they pass through at a
// fixed level of the tree: (node, feature indices) sorted by node id, indices ascending. Matching
// only features that share a node is the direct-index speed-up of ORB-SLAM's SearchByBoW.

#include <cstdint>
#include <vector>

namespace lcv::slam {

using WordId = std::uint32_t;
using NodeId = std::uint32_t;

struct BowEntry {
  WordId word = 0;
  double weight = 0.0;
};
using BowVector = std::vector<BowEntry>;

struct DirectIndexEntry {
  NodeId node = 0;
  std::vector<int> features;  // indices into the image's descriptor array
};
using DirectIndex = std::vector<DirectIndexEntry>;

// The level (below the root) at which the engine builds every direct index, for keyframes and
// frames alike, so that any two can be matched: level 2 is ORB-SLAM's choice (level 4 counted
// from the leaves of its 6-level tree), ~K^2 nodes of features each.
constexpr int kDirectIndexLevel = 2;

// DBoW2's L1 score of two L1-normalized vectors: 1 - |a - b|_1 / 2, in [0, 1], 1 for equal
// vectors, 0 when they share no word. Linear in the number of entries.
double BowL1Score(const BowVector& a, const BowVector& b);

}  // namespace lcv::slam
