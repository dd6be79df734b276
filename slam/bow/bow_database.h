#pragma once
// Inverted-file keyframe database (DBoW2's Database, ORB-SLAM's KeyFrameDatabase without the
// covisibility logic, which belongs to the loop detector and relocalizer in slam/module).
//
// For every word, the keyframes whose BoW vector contains it and their weights. A query visits
// only the lists of its own words, so its cost grows with the number of keyframes sharing words,
// not with the size of the map. Scores are DBoW2's L1 score (BowL1Score), identical to scoring
// the two vectors directly.
//
// Thread safety: none inside (STYLE.md 5): const methods may run concurrently with each other,
// Add/Erase need exclusive access. Keyframes are referred to by id.

#include <cstddef>
#include <unordered_map>
#include <vector>

#include "slam/bow/bow_vector.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct BowQueryResult {
  Id keyframe_id = kInvalidId;
  double score = 0.0;          // L1 score in (0, 1]
  int num_shared_words = 0;    // words present in both vectors
};

class BowDatabase {
 public:
  BowDatabase() = default;

  // Adds a keyframe, or replaces the vector of one already present. bow: sorted by word, as
  // Vocabulary::Transform makes it (checked).
  void Add(Id keyframe_id, const BowVector& bow);
  // No-op for an unknown id.
  void Erase(Id keyframe_id);
  void Clear();
  bool Contains(Id keyframe_id) const { return slot_of_.count(keyframe_id) > 0; }
  std::size_t size() const { return slot_of_.size(); }
  // The keyframes it holds, ascending.
  std::vector<Id> Ids() const;

  // The keyframes sharing at least min_shared_words words with the query, best score first
  // (ties: smaller id first), at most max_results of them (all when max_results <= 0),
  // excluding the ids in `excluded` (any order).
  std::vector<BowQueryResult> Query(const BowVector& query, int max_results,
                                    const std::vector<Id>& excluded = {},
                                    int min_shared_words = 1) const;

 private:
  struct Posting {
    std::uint32_t slot;
    double weight;
  };
  std::vector<std::vector<Posting>> postings_;  // per word
  std::unordered_map<Id, std::uint32_t> slot_of_;
  std::vector<Id> id_of_slot_;                  // kInvalidId for free slots
  std::vector<std::vector<WordId>> words_of_slot_;
  std::vector<std::uint32_t> free_slots_;
};

}  // namespace lcv::slam
