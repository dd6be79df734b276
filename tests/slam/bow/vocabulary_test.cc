#include "slam/bow/vocabulary.h"

#include <cmath>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "slam/util/error.h"
#include "tests/slam/bow/synthetic_descriptors.h"

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 99;

// num_clusters prototypes, copies_per_cluster copies each with `flips` bits flipped, dealt
// round-robin over num_images images. label[i][j] = cluster of descriptor j of image i.
struct ClusteredImages {
  std::vector<std::vector<OrbDescriptor>> images;
  std::vector<std::vector<int>> labels;
};
ClusteredImages MakeClusteredImages(int num_clusters, int copies_per_cluster, int flips,
                                    int num_images, std::mt19937_64& rng) {
  std::vector<OrbDescriptor> prototypes;
  for (int c = 0; c < num_clusters; ++c) prototypes.push_back(test::RandomDescriptor(rng));
  ClusteredImages out;
  out.images.resize(num_images);
  out.labels.resize(num_images);
  int next_image = 0;
  for (int copy = 0; copy < copies_per_cluster; ++copy) {
    for (int c = 0; c < num_clusters; ++c) {
      out.images[next_image].push_back(test::FlipBits(prototypes[c], flips, rng));
      out.labels[next_image].push_back(c);
      next_image = (next_image + 1) % num_images;
    }
  }
  return out;
}

// A "scene": images made of prototypes drawn from a universe, each seen with fresh noise.
std::vector<OrbDescriptor> SceneImage(const std::vector<OrbDescriptor>& universe,
                                      const std::vector<int>& which, int flips,
                                      std::mt19937_64& rng) {
  std::vector<OrbDescriptor> image;
  for (const int p : which) image.push_back(test::FlipBits(universe[p], flips, rng));
  return image;
}

std::vector<int> RandomSubset(int universe_size, int count, std::mt19937_64& rng) {
  std::vector<int> all(universe_size);
  for (int i = 0; i < universe_size; ++i) all[i] = i;
  std::shuffle(all.begin(), all.end(), rng);
  all.resize(count);
  return all;
}

std::string Saved(const Vocabulary& vocabulary) {
  std::ostringstream out;
  vocabulary.Save(out);
  return out.str();
}

Vocabulary LoadFrom(const std::string& bytes) {
  std::istringstream in(bytes);
  return Vocabulary::Load(in, "test.lcvoc");
}

std::uint64_t Fnv1a(const std::string& bytes, std::size_t size) {
  std::uint64_t hash = 1469598103934665603ull;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= static_cast<unsigned char>(bytes[i]);
    hash *= 1099511628211ull;
  }
  return hash;
}

// Rewrites the trailing checksum so that a deliberately corrupted payload reaches the checks
// behind it.
void FixChecksum(std::string* bytes) {
  const std::size_t payload = bytes->size() - 8;
  const std::uint64_t hash = Fnv1a(*bytes, payload);
  for (int i = 0; i < 8; ++i) (*bytes)[payload + i] = static_cast<char>((hash >> (8 * i)) & 0xff);
}

Vocabulary SceneVocabulary(const std::vector<OrbDescriptor>& universe, std::mt19937_64& rng) {
  std::vector<std::vector<OrbDescriptor>> training;
  for (int i = 0; i < 40; ++i) {
    training.push_back(SceneImage(universe, RandomSubset(universe.size(), 300, rng), 10, rng));
  }
  VocabularyOptions options;
  options.branching = 10;
  options.depth = 4;
  return Vocabulary::Train(training, options);
}

TEST(VocabularyOptions, ProblemNamesTheField) {
  EXPECT_FALSE(VocabularyOptions().Problem().has_value());
  VocabularyOptions o;
  o.branching = 1;
  EXPECT_NE(o.Problem().value_or("").find("branching"), std::string::npos);
  o = VocabularyOptions();
  o.depth = 0;
  EXPECT_NE(o.Problem().value_or("").find("depth"), std::string::npos);
  o = VocabularyOptions();
  o.max_iterations = 0;
  EXPECT_NE(o.Problem().value_or("").find("max_iterations"), std::string::npos);
  o = VocabularyOptions();
  o.branching = 100;
  o.depth = 6;
  EXPECT_NE(o.Problem().value_or("").find("4e9"), std::string::npos);
  EXPECT_THROW(Vocabulary::Train({{}}, o), std::logic_error);
}

TEST(Vocabulary, TrainingRecoversSyntheticClusters) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  const ClusteredImages data = MakeClusteredImages(8, 150, 12, 20, rng);
  VocabularyOptions options;
  options.branching = 8;
  options.depth = 1;
  const Vocabulary vocabulary = Vocabulary::Train(data.images, options);
  ASSERT_EQ(vocabulary.num_words(), 8u);
  EXPECT_EQ(vocabulary.num_nodes(), 9u);
  std::map<int, std::set<WordId>> words_of_cluster;
  for (std::size_t i = 0; i < data.images.size(); ++i) {
    for (std::size_t j = 0; j < data.images[i].size(); ++j) {
      words_of_cluster[data.labels[i][j]].insert(vocabulary.WordOf(data.images[i][j]));
    }
  }
  std::set<WordId> used;
  for (const auto& [cluster, words] : words_of_cluster) {
    EXPECT_EQ(words.size(), 1u) << "cluster " << cluster << " split over several words";
    used.insert(*words.begin());
  }
  EXPECT_EQ(used.size(), 8u) << "two clusters merged into one word";
}

TEST(Vocabulary, DeeperTreeKeepsClustersUnderOneTopLevelNode) {
  std::mt19937_64 rng(kSeed + 1);
  const ClusteredImages data = MakeClusteredImages(6, 200, 20, 10, rng);
  VocabularyOptions options;
  options.branching = 6;
  options.depth = 3;
  const Vocabulary vocabulary = Vocabulary::Train(data.images, options);
  EXPECT_GT(vocabulary.num_words(), 6u);
  EXPECT_LE(vocabulary.num_words(), 6u * 6u * 6u);
  // Direct index at level 1: the features of one cluster sit in one node, different clusters
  // in different nodes.
  std::map<int, std::set<NodeId>> nodes_of_cluster;
  std::set<NodeId> all_nodes;
  for (std::size_t i = 0; i < data.images.size(); ++i) {
    BowVector bow;
    DirectIndex index;
    vocabulary.Transform(data.images[i], &bow, &index, 1);
    for (const DirectIndexEntry& entry : index) {
      for (const int f : entry.features) nodes_of_cluster[data.labels[i][f]].insert(entry.node);
    }
  }
  for (const auto& [cluster, nodes] : nodes_of_cluster) {
    EXPECT_EQ(nodes.size(), 1u) << "cluster " << cluster;
    all_nodes.insert(*nodes.begin());
  }
  EXPECT_EQ(all_nodes.size(), 6u);
}

TEST(Vocabulary, TrainingIsDeterministic) {
  std::mt19937_64 rng(kSeed);
  const ClusteredImages data = MakeClusteredImages(5, 40, 30, 7, rng);
  VocabularyOptions options;
  options.branching = 4;
  options.depth = 3;
  EXPECT_EQ(Saved(Vocabulary::Train(data.images, options)),
            Saved(Vocabulary::Train(data.images, options)));
}

TEST(Vocabulary, IdfIgnoresWordsSeenInEveryImage) {
  std::mt19937_64 rng(kSeed);
  const OrbDescriptor everywhere = test::RandomDescriptor(rng);
  const OrbDescriptor half = test::RandomDescriptor(rng);
  std::vector<std::vector<OrbDescriptor>> images(10);
  for (int i = 0; i < 10; ++i) {
    images[i].push_back(test::FlipBits(everywhere, 3, rng));
    if (i < 5) images[i].push_back(test::FlipBits(half, 3, rng));
  }
  VocabularyOptions options;
  options.branching = 2;
  options.depth = 1;
  const Vocabulary vocabulary = Vocabulary::Train(images, options);
  ASSERT_EQ(vocabulary.num_words(), 2u);
  EXPECT_FLOAT_EQ(vocabulary.WordWeight(vocabulary.WordOf(everywhere)), 0.0f);
  EXPECT_FLOAT_EQ(vocabulary.WordWeight(vocabulary.WordOf(half)), std::log(2.0f));
  BowVector bow;
  vocabulary.Transform({everywhere, half, half}, &bow);
  ASSERT_EQ(bow.size(), 1u);
  EXPECT_EQ(bow[0].word, vocabulary.WordOf(half));
  EXPECT_DOUBLE_EQ(bow[0].weight, 1.0);
}

TEST(Vocabulary, TransformGivesSortedNormalizedVectorsAndACompleteDirectIndex) {
  std::mt19937_64 rng(kSeed);
  std::vector<OrbDescriptor> universe;
  for (int i = 0; i < 2000; ++i) universe.push_back(test::RandomDescriptor(rng));
  const Vocabulary vocabulary = SceneVocabulary(universe, rng);
  const std::vector<OrbDescriptor> image =
      SceneImage(universe, RandomSubset(universe.size(), 300, rng), 10, rng);
  for (int level : {0, 1, 2, 3, 7}) {
    BowVector bow;
    DirectIndex index;
    vocabulary.Transform(image, &bow, &index, level);
    double sum = 0.0;
    for (std::size_t i = 0; i < bow.size(); ++i) {
      EXPECT_GT(bow[i].weight, 0.0);
      if (i > 0) {
        EXPECT_LT(bow[i - 1].word, bow[i].word);
      }
      sum += bow[i].weight;
    }
    EXPECT_NEAR(sum, 1.0, 1e-12);
    std::vector<int> seen(image.size(), 0);
    for (std::size_t i = 0; i < index.size(); ++i) {
      if (i > 0) {
        EXPECT_LT(index[i - 1].node, index[i].node);
      }
      for (const int f : index[i].features) ++seen[f];
    }
    for (const int count : seen) EXPECT_EQ(count, 1);
    if (level == 0) {
      ASSERT_EQ(index.size(), 1u);
      EXPECT_EQ(index[0].node, 0u);
    }
  }
  // An empty image and an empty vocabulary give empty outputs.
  BowVector bow = {{1, 1.0}};
  DirectIndex index = {{1, {0}}};
  vocabulary.Transform({}, &bow, &index);
  EXPECT_TRUE(bow.empty());
  EXPECT_TRUE(index.empty());
  const Vocabulary empty = Vocabulary::Train({{}, {}}, VocabularyOptions());
  EXPECT_TRUE(empty.empty());
  empty.Transform(image, &bow, &index);
  EXPECT_TRUE(bow.empty());
}

TEST(Vocabulary, ImageScoresHigherAgainstANoisyCopyThanAgainstUnrelatedImages) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  std::vector<OrbDescriptor> universe;
  for (int i = 0; i < 3000; ++i) universe.push_back(test::RandomDescriptor(rng));
  const Vocabulary vocabulary = SceneVocabulary(universe, rng);
  for (int trial = 0; trial < 10; ++trial) {
    const std::vector<int> seen = RandomSubset(universe.size(), 300, rng);
    // The copy: 80% of the same prototypes with fresh noise, 20% other ones.
    std::vector<int> seen_again(seen.begin(), seen.begin() + 240);
    const std::vector<int> others = RandomSubset(universe.size(), 60, rng);
    seen_again.insert(seen_again.end(), others.begin(), others.end());
    BowVector a, copy, unrelated;
    vocabulary.Transform(SceneImage(universe, seen, 10, rng), &a);
    vocabulary.Transform(SceneImage(universe, seen_again, 10, rng), &copy);
    vocabulary.Transform(
        SceneImage(universe, RandomSubset(universe.size(), 300, rng), 10, rng), &unrelated);
    const double score_copy = BowL1Score(a, copy);
    const double score_unrelated = BowL1Score(a, unrelated);
    // Measured with seed 99: copies 0.25-0.34, unrelated 0.04-0.08.
    EXPECT_GT(score_copy, 3.0 * score_unrelated)
        << "copy " << score_copy << " unrelated " << score_unrelated;
    EXPECT_NEAR(BowL1Score(a, a), 1.0, 1e-12);
    EXPECT_DOUBLE_EQ(BowL1Score(a, copy), BowL1Score(copy, a));
  }
}

TEST(Vocabulary, SaveLoadRoundTrip) {
  std::mt19937_64 rng(kSeed);
  std::vector<OrbDescriptor> universe;
  for (int i = 0; i < 1000; ++i) universe.push_back(test::RandomDescriptor(rng));
  const Vocabulary vocabulary = SceneVocabulary(universe, rng);
  const std::string bytes = Saved(vocabulary);
  const Vocabulary loaded = LoadFrom(bytes);
  EXPECT_EQ(loaded.num_nodes(), vocabulary.num_nodes());
  EXPECT_EQ(loaded.num_words(), vocabulary.num_words());
  EXPECT_EQ(loaded.branching(), 10);
  EXPECT_EQ(loaded.depth(), 4);
  EXPECT_EQ(Saved(loaded), bytes);
  EXPECT_EQ(bytes.size(), 24u + 42u * vocabulary.num_nodes() + 8u);
  const std::vector<OrbDescriptor> image =
      SceneImage(universe, RandomSubset(universe.size(), 200, rng), 10, rng);
  BowVector bow_a, bow_b;
  DirectIndex index_a, index_b;
  vocabulary.Transform(image, &bow_a, &index_a);
  loaded.Transform(image, &bow_b, &index_b);
  ASSERT_EQ(bow_a.size(), bow_b.size());
  for (std::size_t i = 0; i < bow_a.size(); ++i) {
    EXPECT_EQ(bow_a[i].word, bow_b[i].word);
    EXPECT_EQ(bow_a[i].weight, bow_b[i].weight);
  }
  ASSERT_EQ(index_a.size(), index_b.size());
  for (std::size_t i = 0; i < index_a.size(); ++i) {
    EXPECT_EQ(index_a[i].node, index_b[i].node);
    EXPECT_EQ(index_a[i].features, index_b[i].features);
  }
  // The empty vocabulary round-trips too.
  EXPECT_TRUE(LoadFrom(Saved(Vocabulary())).empty());
}

TEST(Vocabulary, BadFilesAreInputErrorsNeverCrashes) {
  std::mt19937_64 rng(kSeed);
  const ClusteredImages data = MakeClusteredImages(6, 30, 40, 5, rng);
  VocabularyOptions options;
  options.branching = 3;
  options.depth = 3;
  const std::string bytes = Saved(Vocabulary::Train(data.images, options));
  const auto message_of = [](const std::string& b) -> std::string {
    try {
      LoadFrom(b);
    } catch (const InputError& e) {
      return e.what();
    }
    return "<loaded>";
  };
  for (std::size_t size : {std::size_t{0}, std::size_t{5}, std::size_t{8}, std::size_t{20},
                           std::size_t{24}, std::size_t{60}, bytes.size() / 2, bytes.size() - 9,
                           bytes.size() - 1}) {
    const std::string message = message_of(bytes.substr(0, size));
    EXPECT_NE(message.find("test.lcvoc"), std::string::npos) << size << ": " << message;
    EXPECT_EQ(message.find("<loaded>"), std::string::npos) << size;
  }
  EXPECT_NE(message_of(bytes.substr(0, bytes.size() - 1)).find("truncated"), std::string::npos);
  EXPECT_NE(message_of("NOTAVOCABULARYFILE").find("magic"), std::string::npos);
  std::string wrong_version = bytes;
  wrong_version[8] = 7;
  EXPECT_NE(message_of(wrong_version).find("version 7"), std::string::npos);
  EXPECT_NE(message_of(bytes + "x").find("unexpected bytes"), std::string::npos);
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  EXPECT_NE(message_of(flipped).find("checksum"), std::string::npos);
  // A structural lie behind a valid checksum: the root keeps its children count but its first
  // child becomes 0 (itself).
  std::string cycle = bytes;
  cycle[24] = cycle[25] = cycle[26] = cycle[27] = 0;
  FixChecksum(&cycle);
  EXPECT_NE(message_of(cycle).find("node 0"), std::string::npos) << message_of(cycle);

  // Random corruptions with a recomputed checksum: loaded or rejected, and a loaded one works.
  std::uniform_int_distribution<std::size_t> position(8, bytes.size() - 9);
  std::uniform_int_distribution<int> value(0, 255);
  int rejected = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::string corrupt = bytes;
    for (int k = 0; k < 3; ++k) corrupt[position(rng)] = static_cast<char>(value(rng));
    FixChecksum(&corrupt);
    try {
      const Vocabulary v = LoadFrom(corrupt);
      BowVector bow;
      DirectIndex index;
      v.Transform(data.images[0], &bow, &index, 2);
    } catch (const InputError&) {
      ++rejected;
    }
  }
  EXPECT_GT(rejected, 0);
}

}  // namespace
}  // namespace lcv::slam
