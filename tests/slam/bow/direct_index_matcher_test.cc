#include "slam/bow/direct_index_matcher.h"

#include <numeric>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "slam/feature/keypoint.h"
#include "slam/bow/vocabulary.h"
#include "tests/slam/bow/synthetic_descriptors.h"

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 8086;
constexpr int kLevel = 1;

TEST(MatchByDirectIndex, MatchesNoisyCopiesOneToOne) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  std::vector<OrbDescriptor> universe;
  for (int i = 0; i < 3000; ++i) universe.push_back(test::RandomDescriptor(rng));
  std::vector<std::vector<OrbDescriptor>> training(30);
  std::uniform_int_distribution<int> pick(0, 2999);
  for (auto& image : training) {
    for (int j = 0; j < 300; ++j) image.push_back(test::FlipBits(universe[pick(rng)], 8, rng));
  }
  VocabularyOptions options;
  options.branching = 8;
  options.depth = 3;
  const Vocabulary vocabulary = Vocabulary::Train(training, options);

  // A: 300 features. B: noisy copies of A's first 250 in shuffled order, plus 100 others.
  std::vector<OrbDescriptor> a, b;
  for (int j = 0; j < 300; ++j) a.push_back(test::FlipBits(universe[pick(rng)], 6, rng));
  std::vector<int> order(250);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  std::vector<int> truth(300, -1);  // truth[index in A] = index in B
  for (int i = 0; i < 250; ++i) {
    truth[order[i]] = static_cast<int>(b.size());
    b.push_back(test::FlipBits(a[order[i]], 10, rng));
  }
  for (int j = 0; j < 100; ++j) b.push_back(test::RandomDescriptor(rng));

  BowVector bow;
  DirectIndex index_a, index_b;
  vocabulary.Transform(a, &bow, &index_a, kLevel);
  vocabulary.Transform(b, &bow, &index_b, kLevel);
  std::vector<DescriptorMatch> matches;
  const int count =
      MatchByDirectIndex(index_a, a, index_b, b, DirectIndexMatchOptions(), &matches);
  EXPECT_EQ(count, static_cast<int>(matches.size()));
  int correct = 0;
  std::set<int> used_b;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    const DescriptorMatch& m = matches[i];
    if (i > 0) {
      EXPECT_LT(matches[i - 1].index_a, m.index_a);
    }
    EXPECT_TRUE(used_b.insert(m.index_b).second) << "feature " << m.index_b << " of B used twice";
    EXPECT_EQ(m.distance, HammingDistance(a[m.index_a], b[m.index_b]));
    EXPECT_LE(m.distance, 50);
    if (truth[m.index_a] == m.index_b) ++correct;
  }
  // Copies are 10 bits away, anything else ~128: every match is right, and every copy that
  // descended into the same node as its original is found. (On structureless random
  // descriptors ~20% of the copies cross a node boundary at level 1.)
  std::vector<NodeId> node_of_a(a.size()), node_of_b(b.size());
  for (const auto& entry : index_a) {
    for (const int f : entry.features) node_of_a[f] = entry.node;
  }
  for (const auto& entry : index_b) {
    for (const int f : entry.features) node_of_b[f] = entry.node;
  }
  int findable = 0;
  for (int i = 0; i < 300; ++i) {
    if (truth[i] >= 0 && node_of_a[i] == node_of_b[truth[i]]) ++findable;
  }
  EXPECT_EQ(correct, count);
  EXPECT_EQ(correct, findable);
  EXPECT_GT(findable, 150);
}

TEST(MatchByDirectIndex, RatioTestAndOneToOne) {
  std::mt19937_64 rng(kSeed);
  const OrbDescriptor x = test::RandomDescriptor(rng);
  // Two candidates equally close to x: ambiguous, rejected by the ratio test.
  const std::vector<OrbDescriptor> a = {x};
  const std::vector<OrbDescriptor> b = {test::FlipBits(x, 5, rng), test::FlipBits(x, 5, rng)};
  const DirectIndex index_a = {{4, {0}}};
  const DirectIndex index_b = {{4, {0, 1}}};
  std::vector<DescriptorMatch> matches;
  EXPECT_EQ(MatchByDirectIndex(index_a, a, index_b, b, DirectIndexMatchOptions(), &matches), 0);
  DirectIndexMatchOptions no_ratio;
  no_ratio.ratio = 1.0f;
  EXPECT_EQ(MatchByDirectIndex(index_a, a, index_b, b, no_ratio, &matches), 0);  // 5 < 5 fails

  // Two features of A wanting the same feature of B: the closer one keeps it.
  const std::vector<OrbDescriptor> a2 = {test::FlipBits(x, 9, rng), test::FlipBits(x, 2, rng)};
  const std::vector<OrbDescriptor> b2 = {x};
  EXPECT_EQ(MatchByDirectIndex({{1, {0, 1}}}, a2, {{1, {0}}}, b2, DirectIndexMatchOptions(),
                               &matches),
            1);
  EXPECT_EQ(matches[0].index_a, 1);
  EXPECT_EQ(matches[0].distance, 2);
  // Different nodes never match; too far never matches.
  EXPECT_EQ(MatchByDirectIndex({{1, {0}}}, a2, {{2, {0}}}, b2, DirectIndexMatchOptions(),
                               &matches),
            0);
  DirectIndexMatchOptions strict;
  strict.max_distance = 1;
  EXPECT_EQ(MatchByDirectIndex({{1, {0, 1}}}, a2, {{1, {0}}}, b2, strict, &matches), 0);
}

}  // namespace
}  // namespace lcv::slam
