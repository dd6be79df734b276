#include "slam/bow/bow_vector.h"

#include <cmath>

namespace lcv::slam {

double BowL1Score(const BowVector& a, const BowVector& b) {
  // With |a|_1 = |b|_1 = 1: |a - b|_1 = 2 - sum over common words of (|a_w| + |b_w| - |a_w - b_w|),
  // so only the common words are visited (DBoW2's L1Scoring).
  double common = 0.0;
  auto ia = a.begin();
  auto ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->word < ib->word) {
      ++ia;
    } else if (ib->word < ia->word) {
      ++ib;
    } else {
      common += std::abs(ia->weight) + std::abs(ib->weight) - std::abs(ia->weight - ib->weight);
      ++ia;
      ++ib;
    }
  }
  return 0.5 * common;
}

}  // namespace lcv::slam
