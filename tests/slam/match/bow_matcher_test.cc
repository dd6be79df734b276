#include "slam/match/bow_matcher.h"

#include <algorithm>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include "slam/bow/vocabulary.h"
#include "tests/slam/bow/synthetic_descriptors.h"

namespace lcv::slam {
namespace {

// A keyframe of 400 keypoints (the even ones hold landmarks 1000 + index) and a frame holding
// noisy copies of all of them in shuffled order, turned by 30 degrees, plus 100 random features;
// 20 of the landmark copies are turned by 60..307 degrees instead (inconsistent orientation,
// scattered: ORB-SLAM's check keeps the three largest bins, so a consistent group would stay).
class BowMatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937_64 rng(77);
    const int n = 400;
    keyframe_.id = 5;
    for (int i = 0; i < n; ++i) {
      keyframe_.keypoints.push_back({10.f + i, 20.f, 10.f, 0});
      keyframe_.descriptors.push_back(test::RandomDescriptor(rng));
      keyframe_.landmark_ids.push_back(i % 2 == 0 ? 1000 + i : kInvalidId);
    }
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    truth_.assign(n + 100, -1);
    int turned = 0;
    for (int k = 0; k < n; ++k) {
      const int i = order[k];
      float angle = 40.f;
      if (i % 2 == 0 && turned < 20) {
        angle = 70.f + 13.f * turned;  // spread over many bins, none near 30 degrees
        ++turned;
        flipped_.push_back(k);
      }
      frame_.keypoints.push_back({5.f + k, 50.f, angle, 0});
      frame_.descriptors.push_back(test::FlipBits(keyframe_.descriptors[i], 8, rng));
      truth_[k] = i;
    }
    for (int j = 0; j < 100; ++j) {
      frame_.keypoints.push_back({1.f, 1.f, 40.f, 0});
      frame_.descriptors.push_back(test::RandomDescriptor(rng));
    }
    VocabularyOptions options;
    options.branching = 8;
    options.depth = 3;
    vocabulary_ = Vocabulary::Train({keyframe_.descriptors, frame_.descriptors}, options);
    vocabulary_.Transform(keyframe_.descriptors, &keyframe_.bow.overwrite(), &keyframe_.direct_index.overwrite(),
                          kDirectIndexLevel);
    vocabulary_.Transform(frame_.descriptors, &frame_.bow, &frame_.direct_index, kDirectIndexLevel);
  }

  SlamKeyframe keyframe_;
  Frame frame_;
  Vocabulary vocabulary_;
  std::vector<int> truth_;    // frame keypoint -> keyframe keypoint (-1: random)
  std::vector<int> flipped_;  // frame keypoints with the inconsistent orientation
};

TEST_F(BowMatcherTest, MatchesOnlyLandmarksWithConsistentOrientation) {
  std::vector<BowLandmarkMatch> matches;
  const int count = MatchKeyframeLandmarksByBow(keyframe_, frame_, BowMatchOptions(), &matches);
  EXPECT_EQ(count, static_cast<int>(matches.size()));
  // 200 landmark copies, ~20% lost to node boundaries on structureless descriptors.
  EXPECT_GT(count, 120);
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const BowLandmarkMatch& m = matches[k];
    if (k > 0) {
      EXPECT_LT(matches[k - 1].frame_keypoint, m.frame_keypoint);
    }
    ASSERT_GE(truth_[m.frame_keypoint], 0) << "a random feature was matched";
    EXPECT_EQ(m.landmark_id, static_cast<Id>(1000 + truth_[m.frame_keypoint]));
    EXPECT_EQ(std::count(flipped_.begin(), flipped_.end(), m.frame_keypoint), 0)
        << "keypoint " << m.frame_keypoint << " with an inconsistent rotation was kept";
    EXPECT_LE(m.distance, 50);
  }
  // Without the orientation check the turned ones come back.
  BowMatchOptions no_check;
  no_check.check_orientation = false;
  std::vector<BowLandmarkMatch> all;
  MatchKeyframeLandmarksByBow(keyframe_, frame_, no_check, &all);
  int turned = 0;
  for (const BowLandmarkMatch& m : all) {
    turned += std::count(flipped_.begin(), flipped_.end(), m.frame_keypoint) > 0;
  }
  EXPECT_GT(turned, 10);
  EXPECT_EQ(all.size(), matches.size() + turned);
}

TEST_F(BowMatcherTest, UnknownAnglesSkipTheOrientationCheck) {
  for (Keypoint& kp : frame_.keypoints) kp.angle_deg = -1.f;
  std::vector<BowLandmarkMatch> matches, unchecked;
  MatchKeyframeLandmarksByBow(keyframe_, frame_, BowMatchOptions(), &matches);
  BowMatchOptions no_check;
  no_check.check_orientation = false;
  MatchKeyframeLandmarksByBow(keyframe_, frame_, no_check, &unchecked);
  EXPECT_EQ(matches.size(), unchecked.size());
}

}  // namespace
}  // namespace lcv::slam
