#include "slam/bow/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "slam/feature/keypoint.h"
#include "slam/util/error.h"

namespace lcv::slam {

std::optional<std::string> VocabularyOptions::Problem() const {
  std::ostringstream out;
  if (branching < 2 || branching > 1000) {
    out << "branching must be in [2, 1000] (is " << branching << ")";
  } else if (depth < 1 || depth > 16) {
    out << "depth must be in [1, 16] (is " << depth << ")";
  } else if (max_iterations < 1) {
    out << "max_iterations must be >= 1 (is " << max_iterations << ")";
  } else if (std::pow(static_cast<double>(branching), depth) > 4.0e9) {
    out << "branching^depth must be <= 4e9 word ids (is " << branching << "^" << depth << ")";
  } else {
    return std::nullopt;
  }
  return out.str();
}

NodeId Vocabulary::Descend(const OrbDescriptor& descriptor, int level,
                           NodeId* node_at_level) const {
  NodeId node = 0;
  NodeId at_level = 0;
  for (int current = 0; node_num_children_[node] > 0;) {
    const NodeId first = node_first_child_[node];
    const NodeId end = first + node_num_children_[node];
    NodeId best = first;
    int best_distance = HammingDistance(descriptor, node_descriptor_[first]);
    for (NodeId child = first + 1; child < end; ++child) {
      const int distance = HammingDistance(descriptor, node_descriptor_[child]);
      if (distance < best_distance) {
        best_distance = distance;
        best = child;
      }
    }
    node = best;
    if (++current <= level) at_level = node;
  }
  if (node_at_level != nullptr) *node_at_level = at_level;
  return node;
}

WordId Vocabulary::WordOf(const OrbDescriptor& descriptor) const {
  LCV_CHECK(!empty()) << "WordOf on an empty vocabulary";
  return node_word_[Descend(descriptor, 0, nullptr)];
}

void Vocabulary::Transform(const std::vector<OrbDescriptor>& descriptors, BowVector* bow,
                           DirectIndex* direct_index, int direct_index_level) const {
  LCV_CHECK(bow != nullptr);
  LCV_CHECK(direct_index_level >= 0) << direct_index_level;
  bow->clear();
  if (direct_index != nullptr) direct_index->clear();
  if (empty() || descriptors.empty()) return;

  // (word, weight) of every feature, then sorted and merged: one allocation per image.
  std::vector<BowEntry> entries;
  entries.reserve(descriptors.size());
  std::vector<std::pair<NodeId, int>> node_feature;
  if (direct_index != nullptr) node_feature.reserve(descriptors.size());
  for (int i = 0; i < static_cast<int>(descriptors.size()); ++i) {
    NodeId node_at_level = 0;
    const NodeId leaf = Descend(descriptors[i], direct_index_level, &node_at_level);
    if (direct_index != nullptr) node_feature.emplace_back(node_at_level, i);
    const double weight = node_weight_[leaf];
    if (weight > 0.0) entries.push_back({node_word_[leaf], weight});
  }

  std::sort(entries.begin(), entries.end(),
            [](const BowEntry& a, const BowEntry& b) { return a.word < b.word; });
  double sum = 0.0;
  for (const BowEntry& entry : entries) {
    if (!bow->empty() && bow->back().word == entry.word) {
      bow->back().weight += entry.weight;
    } else {
      bow->push_back(entry);
    }
    sum += entry.weight;
  }
  if (sum > 0.0) {
    for (BowEntry& entry : *bow) entry.weight /= sum;
  }

  if (direct_index != nullptr) {
    std::sort(node_feature.begin(), node_feature.end());
    for (const auto& [node, feature] : node_feature) {
      if (direct_index->empty() || direct_index->back().node != node) {
        direct_index->push_back({node, {}});
      }
      direct_index->back().features.push_back(feature);
    }
  }
}

void Vocabulary::IndexWords() {
  const std::size_t n = node_descriptor_.size();
  node_word_.assign(n, 0);
  word_node_.clear();
  for (std::size_t node = 0; node < n; ++node) {
    if (node_num_children_[node] == 0) {
      node_word_[node] = static_cast<WordId>(word_node_.size());
      word_node_.push_back(static_cast<NodeId>(node));
    }
  }
}

}  // namespace lcv::slam
