// Candidate server keyframes of a line-cloud relocalization (SelectServerCandidates,
// slam/module/line_cloud_relocalizer.h): the BoW ranking is re-ranked by descriptor votes.
#include <random>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "slam/module/line_cloud_relocalizer.h"

namespace lcv::slam {
namespace {

constexpr Id kFirstServerKeyframe = 1000;  // ids are unique map-wide: lines take 0..179
constexpr int kNumServerKeyframes = 8;
constexpr int kLinesPerKeyframe = 40;  // each keyframe shares half of its lines with the next
constexpr int kLineStride = 20;

OrbDescriptor RandomDescriptor(std::mt19937* rng) {
  OrbDescriptor d;
  for (auto& byte : d) byte = static_cast<std::uint8_t>((*rng)() & 0xff);
  return d;
}

OrbDescriptor FlipBits(OrbDescriptor d, int bits, std::mt19937* rng) {
  for (int i = 0; i < bits; ++i) {
    const int bit = static_cast<int>((*rng)() % 256);
    d[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
  }
  return d;
}

// A street of server keyframes; line l is seen by the keyframes k with
// k * kLineStride <= l < k * kLineStride + kLinesPerKeyframe.
SlamMap MakeStreet(std::mt19937* rng) {
  SlamMap map;
  const int num_lines = kLineStride * (kNumServerKeyframes - 1) + kLinesPerKeyframe;
  for (int l = 0; l < num_lines; ++l) {
    SlamLine& line = map.AddLineWithId(l);
    line.descriptor = RandomDescriptor(rng);
  }
  for (int k = 0; k < kNumServerKeyframes; ++k) {
    SlamServerKeyframe& kf = map.AddServerKeyframeWithId(kFirstServerKeyframe + k);
    for (int l = k * kLineStride; l < k * kLineStride + kLinesPerKeyframe; ++l) {
      kf.line_ids.push_back(l);
      map.mutable_lines().at(l).server_keyframe_ids.push_back(kf.id);
    }
  }
  return map;
}

// The BoW ranking of a scene whose textures repeat: every keyframe scores about the same, and
// the true place (keyframe 1005) comes last.
std::vector<BowQueryResult> FlatRanking() {
  std::vector<BowQueryResult> results;
  double score = 0.03;
  for (const int k : {0, 1, 2, 3, 7, 4, 6, 5}) {
    BowQueryResult r;
    r.keyframe_id = kFirstServerKeyframe + k;
    r.score = score;
    r.num_shared_words = 50;
    results.push_back(r);
    score -= 0.001;
  }
  return results;
}

// What the client triangulated at keyframe 1005's place: 30 of its lines' hidden points (their
// descriptors up to 12 flipped bits) and 30 points of its own that the server never mapped.
std::vector<OrbDescriptor> ClientLandmarks(const SlamMap& map, std::mt19937* rng) {
  std::vector<OrbDescriptor> out;
  const SlamServerKeyframe* kf = map.FindServerKeyframe(kFirstServerKeyframe + 5);
  for (int i = 0; i < 30; ++i) {
    out.push_back(FlipBits(*map.FindLine(kf->line_ids[i])->descriptor, 12, rng));
  }
  for (int i = 0; i < 30; ++i) out.push_back(RandomDescriptor(rng));
  return out;
}

LineCloudRelocalizerOptions CandidateOptions(int max_candidates, int vote_pool) {
  LineCloudRelocalizerOptions options;
  options.max_candidates = max_candidates;
  options.vote_pool = vote_pool;
  return options;
}

class SelectServerCandidatesTest : public ::testing::Test {
 protected:
  std::mt19937 rng_{7};
  const SlamMap map_ = MakeStreet(&rng_);
  const std::vector<OrbDescriptor> landmarks_ = ClientLandmarks(map_, &rng_);
};

TEST_F(SelectServerCandidatesTest, VotesFindThePlaceAFlatBowRankingMisses) {
  const std::vector<Id> candidates =
      SelectServerCandidates(map_, FlatRanking(), landmarks_, CandidateOptions(3, 8));
  ASSERT_EQ(candidates.size(), 3u);
  // Keyframe 1005 sees all 30 matched lines, its neighbours 1004 and 1006 20 and 10 of them.
  EXPECT_EQ(candidates[0], kFirstServerKeyframe + 5);
  EXPECT_EQ(std::set<Id>(candidates.begin() + 1, candidates.end()),
            (std::set<Id>{kFirstServerKeyframe + 4, kFirstServerKeyframe + 6}));
}

TEST_F(SelectServerCandidatesTest, WithoutVotesTheBowOrderIsKept) {
  EXPECT_EQ(SelectServerCandidates(map_, FlatRanking(), landmarks_, CandidateOptions(3, 0)),
            (std::vector<Id>{1000, 1001, 1002}));
  // Nothing to vote with: the BoW order as well.
  EXPECT_EQ(SelectServerCandidates(map_, FlatRanking(), {}, CandidateOptions(3, 8)),
            (std::vector<Id>{1000, 1001, 1002}));
}

TEST_F(SelectServerCandidatesTest, FarDescriptorsDoNotVote) {
  // Only unrelated descriptors (random: ~128 bits from every line): no votes, BoW order.
  std::vector<OrbDescriptor> unrelated;
  for (int i = 0; i < 40; ++i) unrelated.push_back(RandomDescriptor(&rng_));
  EXPECT_EQ(SelectServerCandidates(map_, FlatRanking(), unrelated, CandidateOptions(2, 8)),
            (std::vector<Id>{1000, 1001}));
}

TEST_F(SelectServerCandidatesTest, FewerResultsThanCandidatesReturnsThemAll) {
  std::vector<BowQueryResult> results = FlatRanking();
  results.resize(2);
  const LineCloudRelocalizerOptions options = CandidateOptions(5, 20);
  EXPECT_EQ(SelectServerCandidates(map_, results, landmarks_, options).size(), 2u);
  EXPECT_TRUE(SelectServerCandidates(map_, {}, landmarks_, options).empty());
}

}  // namespace
}  // namespace lcv::slam
