#include "slam/bow/direct_index_matcher.h"

#include <algorithm>
#include <limits>

#include "slam/feature/keypoint.h"
#include "slam/util/error.h"

namespace lcv::slam {

int MatchByDirectIndex(const DirectIndex& index_a, const std::vector<OrbDescriptor>& descriptors_a,
                       const DirectIndex& index_b, const std::vector<OrbDescriptor>& descriptors_b,
                       const DirectIndexMatchOptions& options,
                       std::vector<DescriptorMatch>* matches) {
  LCV_CHECK(matches != nullptr);
  LCV_CHECK(options.ratio > 0.f && options.ratio <= 1.f) << options.ratio;
  matches->clear();
  // best_for_b[j]: the match currently holding feature j of B (index into *matches), or -1.
  std::vector<int> best_for_b(descriptors_b.size(), -1);
  auto ia = index_a.begin();
  auto ib = index_b.begin();
  while (ia != index_a.end() && ib != index_b.end()) {
    if (ia->node < ib->node) {
      ++ia;
      continue;
    }
    if (ib->node < ia->node) {
      ++ib;
      continue;
    }
    for (const int a : ia->features) {
      LCV_CHECK(a >= 0 && a < static_cast<int>(descriptors_a.size())) << "feature " << a;
      NearestTwo nearest;
      for (const int b : ib->features) {
        LCV_CHECK(b >= 0 && b < static_cast<int>(descriptors_b.size())) << "feature " << b;
        nearest.Offer(HammingDistance(descriptors_a[a], descriptors_b[b]), b);
      }
      const int best = nearest.best, second = nearest.second, best_b = nearest.index;
      if (best_b < 0 || best > options.max_distance) continue;
      if (second != NearestTwo::kNone &&
          !(static_cast<float>(best) < options.ratio * static_cast<float>(second))) {
        continue;
      }
      int& holder = best_for_b[best_b];
      if (holder >= 0) {
        DescriptorMatch& previous = (*matches)[holder];
        if (previous.distance < best || (previous.distance == best && previous.index_a < a)) {
          continue;
        }
        previous.index_a = -1;  // superseded, removed below
      }
      holder = static_cast<int>(matches->size());
      matches->push_back({a, best_b, best});
    }
    ++ia;
    ++ib;
  }
  matches->erase(std::remove_if(matches->begin(), matches->end(),
                                [](const DescriptorMatch& m) { return m.index_a < 0; }),
                 matches->end());
  std::sort(matches->begin(), matches->end(),
            [](const DescriptorMatch& x, const DescriptorMatch& y) { return x.index_a < y.index_a; });
  return static_cast<int>(matches->size());
}

}  // namespace lcv::slam
