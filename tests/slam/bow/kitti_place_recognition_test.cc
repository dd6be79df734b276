// Place recognition on real images: a vocabulary trained on KITTI 00's even frames retrieves, for
// each odd frame, a neighbouring even frame through the inverted-file database. Needs
// ../shared/data/kitti00 (skipped without it).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "slam/bow/bow_database.h"
#include "slam/bow/direct_index_matcher.h"
#include "slam/bow/vocabulary.h"
#include "slam/feature/orb_extractor.h"

namespace lcv::slam {
namespace {

std::string KittiImage(int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.png", index);
  return std::string(LCV_SHARED_DIR) + "/data/kitti00/image_0/" + name;
}

TEST(KittiPlaceRecognition, OddFramesFindTheirEvenNeighbours) {
  constexpr int kNumFrames = 120;
  if (!std::filesystem::exists(KittiImage(kNumFrames - 1))) {
    GTEST_SKIP() << "KITTI 00 images not found under " << LCV_SHARED_DIR
                 << "/data/kitti00/image_0 (frames 0.." << kNumFrames - 1 << " needed)";
  }
  OrbExtractorOptions extractor_options;
  extractor_options.num_features = 800;
  OrbExtractor extractor(extractor_options);
  std::vector<Keypoint> keypoints;
  const auto descriptors_of = [&](int frame) {
    const cv::Mat image = cv::imread(KittiImage(frame), cv::IMREAD_GRAYSCALE);
    EXPECT_FALSE(image.empty()) << KittiImage(frame);
    std::vector<OrbDescriptor> descriptors;
    extractor.Extract(image, cv::Mat(), &keypoints, &descriptors);
    return descriptors;
  };

  std::vector<std::vector<OrbDescriptor>> even;
  for (int frame = 0; frame < kNumFrames; frame += 2) even.push_back(descriptors_of(frame));
  VocabularyOptions options;
  options.branching = 10;
  options.depth = 4;
  const Vocabulary vocabulary = Vocabulary::Train(even, options);
  ASSERT_GT(vocabulary.num_words(), 1000u);

  BowDatabase database;
  std::vector<DirectIndex> even_index(even.size());
  for (std::size_t i = 0; i < even.size(); ++i) {
    BowVector bow;
    vocabulary.Transform(even[i], &bow, &even_index[i], 2);
    database.Add(static_cast<Id>(2 * i), bow);
  }

  int queries = 0, retrieved = 0, enough_matches = 0;
  for (int frame = 1; frame < kNumFrames; frame += 6) {
    const std::vector<OrbDescriptor> descriptors = descriptors_of(frame);
    BowVector bow;
    DirectIndex index;
    vocabulary.Transform(descriptors, &bow, &index, 2);
    const std::vector<BowQueryResult> best = database.Query(bow, 1);
    ASSERT_EQ(best.size(), 1u);
    ++queries;
    const int found = static_cast<int>(best[0].keyframe_id);
    if (std::abs(found - frame) <= 3) ++retrieved;
    // The neighbour's features match through the direct index.
    std::vector<DescriptorMatch> matches;
    const int neighbour = (frame - 1) / 2;
    MatchByDirectIndex(index, descriptors, even_index[neighbour], even[neighbour],
                       DirectIndexMatchOptions(), &matches);
    if (matches.size() >= 100) ++enough_matches;
    std::printf("frame %d: best %d (score %.3f), %zu direct-index matches with frame %d\n", frame,
                found, best[0].score, matches.size(), 2 * neighbour);
  }
  // Measured (800 features, K=10, L=4): all 20 queries retrieve a frame 1 away, with 149-239
  // direct-index matches to the preceding even frame.
  EXPECT_GE(retrieved, queries - 1) << retrieved << " of " << queries;
  EXPECT_GE(enough_matches, queries - 1) << enough_matches << " of " << queries;
}

}  // namespace
}  // namespace lcv::slam
