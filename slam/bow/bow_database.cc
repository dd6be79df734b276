#include "slam/bow/bow_database.h"

#include <algorithm>
#include <cmath>

#include "slam/util/error.h"

namespace lcv::slam {

std::vector<Id> BowDatabase::Ids() const {
  std::vector<Id> ids;
  ids.reserve(slot_of_.size());
  for (const auto& [id, slot] : slot_of_) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

void BowDatabase::Add(Id keyframe_id, const BowVector& bow) {
  LCV_CHECK(keyframe_id != kInvalidId);
  for (std::size_t i = 1; i < bow.size(); ++i) {
    LCV_CHECK(bow[i - 1].word < bow[i].word) << "BoW vector not sorted by word at entry " << i;
  }
  Erase(keyframe_id);
  std::uint32_t slot;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<std::uint32_t>(id_of_slot_.size());
    id_of_slot_.push_back(kInvalidId);
    words_of_slot_.emplace_back();
  }
  id_of_slot_[slot] = keyframe_id;
  slot_of_[keyframe_id] = slot;
  std::vector<WordId>& words = words_of_slot_[slot];
  words.clear();
  for (const BowEntry& entry : bow) {
    if (entry.word >= postings_.size()) postings_.resize(entry.word + 1);
    postings_[entry.word].push_back({slot, entry.weight});
    words.push_back(entry.word);
  }
}

void BowDatabase::Erase(Id keyframe_id) {
  const auto it = slot_of_.find(keyframe_id);
  if (it == slot_of_.end()) return;
  const std::uint32_t slot = it->second;
  for (const WordId word : words_of_slot_[slot]) {
    std::vector<Posting>& list = postings_[word];
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (list[i].slot == slot) {
        list[i] = list.back();
        list.pop_back();
        break;
      }
    }
  }
  words_of_slot_[slot].clear();
  id_of_slot_[slot] = kInvalidId;
  free_slots_.push_back(slot);
  slot_of_.erase(it);
}

void BowDatabase::Clear() {
  postings_.clear();
  slot_of_.clear();
  id_of_slot_.clear();
  words_of_slot_.clear();
  free_slots_.clear();
}

std::vector<BowQueryResult> BowDatabase::Query(const BowVector& query, int max_results,
                                               const std::vector<Id>& excluded,
                                               int min_shared_words) const {
  // Per slot: sum over common words of |q| + |w| - |q - w| (DBoW2's L1), and the common count.
  std::vector<double> accumulated(id_of_slot_.size(), 0.0);
  std::vector<int> shared(id_of_slot_.size(), 0);
  for (const BowEntry& entry : query) {
    if (entry.word >= postings_.size()) continue;
    for (const Posting& posting : postings_[entry.word]) {
      accumulated[posting.slot] += std::abs(entry.weight) + std::abs(posting.weight) -
                                   std::abs(entry.weight - posting.weight);
      ++shared[posting.slot];
    }
  }
  for (const Id id : excluded) {
    const auto it = slot_of_.find(id);
    if (it != slot_of_.end()) shared[it->second] = 0;
  }
  std::vector<BowQueryResult> results;
  for (std::size_t slot = 0; slot < id_of_slot_.size(); ++slot) {
    if (shared[slot] > 0 && shared[slot] >= min_shared_words) {
      results.push_back({id_of_slot_[slot], 0.5 * accumulated[slot], shared[slot]});
    }
  }
  const auto better = [](const BowQueryResult& a, const BowQueryResult& b) {
    return a.score != b.score ? a.score > b.score : a.keyframe_id < b.keyframe_id;
  };
  if (max_results > 0 && static_cast<int>(results.size()) > max_results) {
    std::partial_sort(results.begin(), results.begin() + max_results, results.end(), better);
    results.resize(max_results);
  } else {
    std::sort(results.begin(), results.end(), better);
  }
  return results;
}

}  // namespace lcv::slam
