// Vocabulary::Train: hierarchical k-majority clustering with k-means++ seeding, then idf weights.
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <random>

#include "slam/feature/keypoint.h"
#include "slam/bow/vocabulary.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// Bitwise majority of the members (bit set when more than half of them have it, as DBoW2's
// binary mean).
OrbDescriptor MajorityCentre(const std::vector<OrbDescriptor>& descriptors,
                             const std::uint32_t* members, int count) {
  std::array<int, 256> ones{};
  for (int m = 0; m < count; ++m) {
    const OrbDescriptor& d = descriptors[members[m]];
    for (int byte = 0; byte < 32; ++byte) {
      const unsigned value = d[byte];
      for (int bit = 0; bit < 8; ++bit) ones[8 * byte + bit] += (value >> bit) & 1u;
    }
  }
  OrbDescriptor centre{};
  for (int byte = 0; byte < 32; ++byte) {
    unsigned value = 0;
    for (int bit = 0; bit < 8; ++bit) {
      if (2 * ones[8 * byte + bit] > count) value |= 1u << bit;
    }
    centre[byte] = static_cast<std::uint8_t>(value);
  }
  return centre;
}

// Clusters the members into at most k groups. Returns the centres; cluster[m] is the group of
// members[m]. Fewer than two centres means the members cannot be split (all equal).
std::vector<OrbDescriptor> KMajority(const std::vector<OrbDescriptor>& descriptors,
                                     const std::uint32_t* members, int count, int k,
                                     int max_iterations, std::mt19937_64& rng,
                                     std::vector<int>* cluster) {
  cluster->assign(count, 0);
  std::vector<OrbDescriptor> centres;

  // k-means++ seeding (Arthur and Vassilvitskii 2007): the next seed is drawn with probability
  // proportional to the squared distance to the nearest seed so far. Duplicates of a seed have
  // weight 0, so at most the number of distinct descriptors is seeded.
  std::vector<double> nearest_sq(count);
  centres.push_back(descriptors[members[std::uniform_int_distribution<int>(0, count - 1)(rng)]]);
  for (int m = 0; m < count; ++m) {
    const double d = HammingDistance(descriptors[members[m]], centres[0]);
    nearest_sq[m] = d * d;
  }
  while (static_cast<int>(centres.size()) < k) {
    const double total = std::accumulate(nearest_sq.begin(), nearest_sq.end(), 0.0);
    if (total <= 0.0) break;
    double target = std::uniform_real_distribution<double>(0.0, total)(rng);
    int chosen = count - 1;
    for (int m = 0; m < count; ++m) {
      target -= nearest_sq[m];
      if (target < 0.0 && nearest_sq[m] > 0.0) {
        chosen = m;
        break;
      }
    }
    while (nearest_sq[chosen] <= 0.0) --chosen;  // rounding at the end of the walk
    centres.push_back(descriptors[members[chosen]]);
    for (int m = 0; m < count; ++m) {
      const double d = HammingDistance(descriptors[members[m]], centres.back());
      nearest_sq[m] = std::min(nearest_sq[m], d * d);
    }
  }
  if (centres.size() < 2) return centres;

  // Lloyd iterations with Hamming distance and majority centres.
  const int num_centres = static_cast<int>(centres.size());
  std::vector<std::uint32_t> grouped(count);
  std::vector<int> group_begin(num_centres + 1);
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    bool changed = iteration == 0;
    for (int m = 0; m < count; ++m) {
      int best = 0;
      int best_distance = HammingDistance(descriptors[members[m]], centres[0]);
      for (int c = 1; c < num_centres; ++c) {
        const int distance = HammingDistance(descriptors[members[m]], centres[c]);
        if (distance < best_distance) {
          best_distance = distance;
          best = c;
        }
      }
      if ((*cluster)[m] != best) changed = true;
      (*cluster)[m] = best;
    }
    if (!changed || iteration + 1 == max_iterations) break;
    // Counting sort of the members by cluster, then the new centres.
    std::fill(group_begin.begin(), group_begin.end(), 0);
    for (int m = 0; m < count; ++m) ++group_begin[(*cluster)[m] + 1];
    std::partial_sum(group_begin.begin(), group_begin.end(), group_begin.begin());
    std::vector<int> fill = group_begin;
    for (int m = 0; m < count; ++m) grouped[fill[(*cluster)[m]]++] = members[m];
    for (int c = 0; c < num_centres; ++c) {
      const int size = group_begin[c + 1] - group_begin[c];
      if (size > 0) centres[c] = MajorityCentre(descriptors, &grouped[group_begin[c]], size);
      // An emptied cluster keeps its centre; it is dropped below if it stays empty.
    }
  }

  // Drop empty clusters and renumber.
  std::vector<int> size(num_centres, 0);
  for (int m = 0; m < count; ++m) ++size[(*cluster)[m]];
  std::vector<int> renumber(num_centres, -1);
  std::vector<OrbDescriptor> kept;
  for (int c = 0; c < num_centres; ++c) {
    if (size[c] > 0) {
      renumber[c] = static_cast<int>(kept.size());
      kept.push_back(centres[c]);
    }
  }
  for (int m = 0; m < count; ++m) (*cluster)[m] = renumber[(*cluster)[m]];
  return kept;
}

}  // namespace

Vocabulary Vocabulary::Train(const std::vector<std::vector<OrbDescriptor>>& descriptors_per_image,
                             const VocabularyOptions& options) {
  const std::optional<std::string> problem = options.Problem();
  LCV_CHECK(!problem) << *problem;
  std::vector<OrbDescriptor> descriptors;
  for (const auto& image : descriptors_per_image) {
    descriptors.insert(descriptors.end(), image.begin(), image.end());
  }
  Vocabulary vocabulary;
  vocabulary.branching_ = options.branching;
  vocabulary.depth_ = options.depth;
  if (descriptors.empty()) return vocabulary;
  LCV_CHECK(descriptors.size() < (1u << 31)) << descriptors.size() << " descriptors";

  // The tree, grown depth-first. Every node's members are a contiguous range of `order`,
  // reordered by cluster when the node splits; its children are allocated together.
  const auto add_node = [&vocabulary](const OrbDescriptor& descriptor) {
    vocabulary.node_descriptor_.push_back(descriptor);
    vocabulary.node_first_child_.push_back(0);
    vocabulary.node_num_children_.push_back(0);
    return static_cast<NodeId>(vocabulary.node_descriptor_.size() - 1);
  };
  add_node(OrbDescriptor{});
  std::vector<std::uint32_t> order(descriptors.size());
  std::iota(order.begin(), order.end(), 0u);
  struct Task {
    NodeId node;
    int level;
    std::size_t begin, end;
  };
  std::vector<Task> stack = {{0, 0, 0, descriptors.size()}};
  std::mt19937_64 rng(options.seed);
  std::vector<int> cluster;
  std::vector<std::uint32_t> scratch;
  while (!stack.empty()) {
    const Task task = stack.back();
    stack.pop_back();
    if (task.level >= options.depth || task.end - task.begin < 2) continue;  // a leaf
    const int count = static_cast<int>(task.end - task.begin);
    const std::vector<OrbDescriptor> centres =
        KMajority(descriptors, &order[task.begin], count, options.branching,
                  options.max_iterations, rng, &cluster);
    if (centres.size() < 2) continue;  // identical descriptors: a leaf

    const int num_children = static_cast<int>(centres.size());
    std::vector<std::size_t> child_begin(num_children + 1, 0);
    for (int m = 0; m < count; ++m) ++child_begin[cluster[m] + 1];
    std::partial_sum(child_begin.begin(), child_begin.end(), child_begin.begin());
    scratch.assign(order.begin() + task.begin, order.begin() + task.end);
    std::vector<std::size_t> fill = child_begin;
    for (int m = 0; m < count; ++m) order[task.begin + fill[cluster[m]]++] = scratch[m];

    const NodeId first_child = add_node(centres[0]);
    for (int c = 1; c < num_children; ++c) add_node(centres[c]);
    vocabulary.node_first_child_[task.node] = first_child;
    vocabulary.node_num_children_[task.node] = static_cast<std::uint16_t>(num_children);
    // Pushed in reverse so that the first child is refined first (no effect on the result's
    // structure, only on the RNG stream, which stays deterministic either way).
    for (int c = num_children - 1; c >= 0; --c) {
      stack.push_back({first_child + c, task.level + 1, task.begin + child_begin[c],
                       task.begin + child_begin[c + 1]});
    }
  }
  vocabulary.IndexWords();

  // idf = log(N / n_w) over the training images, counting each image once per word. A word that
  // no training descriptor reaches by descent (its centre moved) counts as seen once.
  const std::size_t num_images = descriptors_per_image.size();
  std::vector<std::uint32_t> images_with_word(vocabulary.num_words(), 0);
  std::vector<std::int64_t> last_image(vocabulary.num_words(), -1);
  for (std::size_t image = 0; image < num_images; ++image) {
    for (const OrbDescriptor& descriptor : descriptors_per_image[image]) {
      const WordId word = vocabulary.node_word_[vocabulary.Descend(descriptor, 0, nullptr)];
      if (last_image[word] != static_cast<std::int64_t>(image)) {
        last_image[word] = static_cast<std::int64_t>(image);
        ++images_with_word[word];
      }
    }
  }
  vocabulary.node_weight_.assign(vocabulary.num_nodes(), 0.0f);
  for (WordId word = 0; word < vocabulary.num_words(); ++word) {
    const double seen_in = std::max<std::uint32_t>(images_with_word[word], 1);
    vocabulary.node_weight_[vocabulary.word_node_[word]] =
        static_cast<float>(std::log(static_cast<double>(num_images) / seen_in));
  }
  return vocabulary;
}

}  // namespace lcv::slam
