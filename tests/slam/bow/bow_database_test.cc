#include "slam/bow/bow_database.h"

#include <random>

#include <gtest/gtest.h>

#include "slam/bow/vocabulary.h"
#include "tests/slam/bow/synthetic_descriptors.h"

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 5150;

TEST(BowL1Score, HandExamples) {
  const BowVector a = {{1, 0.5}, {2, 0.5}};
  const BowVector b = {{2, 0.5}, {3, 0.5}};
  EXPECT_DOUBLE_EQ(BowL1Score(a, b), 0.5);
  EXPECT_DOUBLE_EQ(BowL1Score(a, a), 1.0);
  EXPECT_DOUBLE_EQ(BowL1Score(a, {{7, 1.0}}), 0.0);
  EXPECT_DOUBLE_EQ(BowL1Score(a, {}), 0.0);
  // 1 - |a - b|_1 / 2 = 1 - (0.4 + 0.4) / 2.
  EXPECT_NEAR(BowL1Score({{1, 0.2}, {2, 0.8}}, {{1, 0.6}, {2, 0.4}}), 0.6, 1e-15);
}

class BowDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937_64 rng(kSeed);
    for (int i = 0; i < 4000; ++i) universe_.push_back(test::RandomDescriptor(rng));
    std::vector<std::vector<OrbDescriptor>> training;
    for (int i = 0; i < 30; ++i) training.push_back(Image(Subset(300, rng), rng));
    VocabularyOptions options;
    options.branching = 10;
    options.depth = 3;
    vocabulary_ = Vocabulary::Train(training, options);
    for (int k = 0; k < 50; ++k) keyframe_prototypes_.push_back(Subset(300, rng));
  }
  std::vector<int> Subset(int count, std::mt19937_64& rng) const {
    std::vector<int> all(universe_.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    std::shuffle(all.begin(), all.end(), rng);
    all.resize(count);
    return all;
  }
  std::vector<OrbDescriptor> Image(const std::vector<int>& which, std::mt19937_64& rng) const {
    std::vector<OrbDescriptor> image;
    for (const int p : which) image.push_back(test::FlipBits(universe_[p], 10, rng));
    return image;
  }
  BowVector Bow(const std::vector<OrbDescriptor>& image) const {
    BowVector bow;
    vocabulary_.Transform(image, &bow);
    return bow;
  }
  static Id KeyframeId(int k) { return 1000 + 7 * static_cast<Id>(k); }

  std::vector<OrbDescriptor> universe_;
  Vocabulary vocabulary_;
  std::vector<std::vector<int>> keyframe_prototypes_;
};

TEST_F(BowDatabaseTest, QueryFindsTheKeyframeOfANoisyView) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed + 1);
  BowDatabase database;
  std::vector<BowVector> stored;
  for (int k = 0; k < 50; ++k) {
    stored.push_back(Bow(Image(keyframe_prototypes_[k], rng)));
    database.Add(KeyframeId(k), stored.back());
  }
  EXPECT_EQ(database.size(), 50u);
  for (int k = 0; k < 50; k += 7) {
    // A new view: 75% of the keyframe's prototypes, fresh noise.
    const std::vector<int> view(keyframe_prototypes_[k].begin(),
                                keyframe_prototypes_[k].begin() + 225);
    const BowVector query = Bow(Image(view, rng));
    const std::vector<BowQueryResult> results = database.Query(query, 5);
    ASSERT_EQ(results.size(), 5u);
    EXPECT_EQ(results[0].keyframe_id, KeyframeId(k));
    for (std::size_t i = 0; i < results.size(); ++i) {
      if (i > 0) {
        EXPECT_GE(results[i - 1].score, results[i].score);
      }
      // Scores equal direct scoring of the two vectors.
      const int stored_index = static_cast<int>((results[i].keyframe_id - 1000) / 7);
      EXPECT_NEAR(results[i].score, BowL1Score(query, stored[stored_index]), 1e-12);
      EXPECT_GT(results[i].num_shared_words, 0);
    }
    // Excluding the right answer promotes the runner-up.
    const auto without = database.Query(query, 5, {KeyframeId(k), 123456});
    ASSERT_FALSE(without.empty());
    EXPECT_EQ(without[0].keyframe_id, results[1].keyframe_id);
  }
}

TEST_F(BowDatabaseTest, EraseReplaceAndFilters) {
  std::mt19937_64 rng(kSeed + 2);
  BowDatabase database;
  const BowVector a = Bow(Image(keyframe_prototypes_[0], rng));
  const BowVector b = Bow(Image(keyframe_prototypes_[1], rng));
  database.Add(1, a);
  database.Add(2, b);
  EXPECT_TRUE(database.Contains(1));
  auto results = database.Query(a, 0);
  ASSERT_GE(results.size(), 1u);
  EXPECT_EQ(results[0].keyframe_id, 1u);
  EXPECT_NEAR(results[0].score, 1.0, 1e-12);
  EXPECT_EQ(results[0].num_shared_words, static_cast<int>(a.size()));

  // Replacing keyframe 1 by b's vector: both now score 1 against b, ties by id.
  database.Add(1, b);
  EXPECT_EQ(database.size(), 2u);
  results = database.Query(b, 0);
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[0].keyframe_id, 1u);
  EXPECT_EQ(results[1].keyframe_id, 2u);
  EXPECT_NEAR(results[1].score, 1.0, 1e-12);
  EXPECT_TRUE(database.Query(a, 0, {}, static_cast<int>(a.size()) + 1).empty());

  database.Erase(2);
  database.Erase(99);  // unknown: no-op
  EXPECT_FALSE(database.Contains(2));
  results = database.Query(b, 0);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].keyframe_id, 1u);
  // The freed slot is reused without mixing vectors.
  database.Add(3, a);
  results = database.Query(a, 1);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].keyframe_id, 3u);
  EXPECT_NEAR(results[0].score, 1.0, 1e-12);

  database.Clear();
  EXPECT_EQ(database.size(), 0u);
  EXPECT_TRUE(database.Query(a, 10).empty());
  EXPECT_THROW(database.Add(4, {{5, 0.5}, {2, 0.5}}), std::logic_error);  // not sorted
}

}  // namespace
}  // namespace lcv::slam
