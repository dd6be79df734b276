#pragma once
// Vocabulary tree for binary ORB descriptors (DBoW2: Galvez-Lopez and Tardos, "Bags of Binary
// Words for Fast Place Recognition in Image Sequences", T-RO 2012).
//
// Training: hierarchical k-majority clustering (Grana et al. 2013: the centre of a cluster of
// binary descriptors is their bitwise majority, distances are Hamming) with k-means++ seeding,
// `branching` children per node, down to `depth` levels; a node with a single distinct
// descriptor stops early. The leaves are the words. Each word gets the inverse document
// frequency weight idf = log(N / n_w) of the N training images, n_w of which contain it (a word
// present in every image weighs 0 and is ignored).
//
// Transform: each descriptor descends from the root to the child at the smallest Hamming
// distance (ties: the first child); the BoW vector sums the idf of the words reached and is
// L1-normalized. The direct index records, for each feature, the node it passed at a given level
// (level 0 is the root; a path shorter than the level ends at its leaf).
//
// File format (Save / Load), little-endian:
//   "LCVVOCAB" (8 bytes), uint32 version = 1, uint32 branching, uint32 depth,
//   uint32 num_nodes, then per node: uint32 first_child (0 = leaf), uint16 num_children,
//   32 descriptor bytes, float32 weight (leaves; 0 for inner nodes);
//   then uint64 FNV-1a checksum of every byte before it.
// Node 0 is the root; a node's children are contiguous and come after it; words are numbered by
// increasing node id. A vocabulary of 10^6 words is ~40 MB and loads in a few hundred ms.
//
// Thread safety: immutable after Train/Load; every const method may run concurrently.

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "slam/bow/bow_vector.h"
#include "slam/feature/keypoint.h"

namespace lcv::slam {

struct VocabularyOptions {
  int branching = 10;       // K, children per node, >= 2
  int depth = 6;            // L, levels below the root, >= 1; K^L words at most
  int max_iterations = 10;  // k-majority iterations per node, >= 1
  std::uint64_t seed = 1;   // k-means++ seeding

  // Empty when usable, else what is wrong ("branching must be >= 2").
  std::optional<std::string> Problem() const;
};

class Vocabulary {
 public:
  Vocabulary() = default;  // empty: no words

  // Trains on the descriptors of a set of images (one vector per image, for the idf).
  // Deterministic for given inputs and options. Precondition: !options.Problem() (checked).
  // An input without any descriptor gives an empty vocabulary.
  static Vocabulary Train(const std::vector<std::vector<OrbDescriptor>>& descriptors_per_image,
                          const VocabularyOptions& options);

  bool empty() const { return word_node_.empty(); }
  int branching() const { return branching_; }
  int depth() const { return depth_; }
  std::size_t num_nodes() const { return node_descriptor_.size(); }
  std::size_t num_words() const { return word_node_.size(); }
  double WordWeight(WordId word) const { return node_weight_[word_node_[word]]; }

  // The word of one descriptor. Precondition: !empty().
  WordId WordOf(const OrbDescriptor& descriptor) const;

  // BoW vector of one image, and optionally its direct index at direct_index_level (>= 0).
  // Clears and fills the outputs. An empty vocabulary gives empty outputs.
  void Transform(const std::vector<OrbDescriptor>& descriptors, BowVector* bow,
                 DirectIndex* direct_index = nullptr, int direct_index_level = 2) const;

  void Save(std::ostream& out) const;
  // Reads what Save wrote. Throws lcv::InputError("<source_name>: <problem>") on a wrong magic,
  // version, truncation, bad checksum or inconsistent tree; never crashes on any input.
  static Vocabulary Load(std::istream& in, const std::string& source_name);

 private:
  // Descends from the root; returns the leaf node, and the node at `level` in *node_at_level.
  NodeId Descend(const OrbDescriptor& descriptor, int level, NodeId* node_at_level) const;
  // Numbers the leaves as words (increasing node id); checks the tree's structure.
  void IndexWords();

  int branching_ = 0;
  int depth_ = 0;
  // Per node.
  std::vector<OrbDescriptor> node_descriptor_;
  std::vector<std::uint32_t> node_first_child_;  // 0 for leaves
  std::vector<std::uint16_t> node_num_children_;
  std::vector<float> node_weight_;  // idf, leaves only
  std::vector<WordId> node_word_;   // leaves only
  // Per word.
  std::vector<NodeId> word_node_;
};

}  // namespace lcv::slam
