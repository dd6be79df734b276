// The loop-closing stage's own keyframe database (SyncDatabaseWithMap) against the writer's: the
// same keyframes and the same query answers after keyframes are added, culled and the map reset.
#include <gtest/gtest.h>

#include <vector>

#include "slam/loop_closing.h"

namespace lcv::slam {
namespace {

Frame FrameWithWords(std::vector<BowEntry> bow) {
  Frame frame;
  frame.bow = std::move(bow);
  return frame;
}

void ExpectSameAnswers(const BowDatabase& a, const BowDatabase& b,
                       const std::vector<BowVector>& queries) {
  EXPECT_EQ(a.Ids(), b.Ids());
  for (const BowVector& query : queries) {
    const auto ra = a.Query(query, 0);
    const auto rb = b.Query(query, 0);
    ASSERT_EQ(ra.size(), rb.size());
    for (size_t i = 0; i < ra.size(); ++i) {
      EXPECT_EQ(ra[i].keyframe_id, rb[i].keyframe_id);
      EXPECT_EQ(ra[i].score, rb[i].score);
    }
  }
}

TEST(SyncDatabaseWithMap, HoldsTheMapsKeyframesAsTheWritersDatabaseDoes) {
  const std::vector<BowVector> words = {
      {{1, 0.5}, {4, 0.5}}, {{1, 0.25}, {2, 0.75}}, {{2, 0.5}, {4, 0.5}}, {{3, 1.0}},
      {{1, 0.5}, {3, 0.5}}};
  SlamMap map;
  BowDatabase writer;  // as local mapping keeps it
  BowDatabase mirror;  // as the loop stage keeps it
  std::vector<Id> ids;
  for (int i = 0; i < 3; ++i) {
    ids.push_back(map.AddKeyframe(FrameWithWords(words[i])).id);
    writer.Add(ids.back(), words[i]);
  }
  SyncDatabaseWithMap(map, &mirror);
  ExpectSameAnswers(writer, mirror, words);

  map.EraseKeyframe(ids[1]);  // culled
  writer.Erase(ids[1]);
  for (int i = 3; i < 5; ++i) {
    ids.push_back(map.AddKeyframe(FrameWithWords(words[i])).id);
    writer.Add(ids.back(), words[i]);
  }
  SyncDatabaseWithMap(map, &mirror);
  EXPECT_EQ(mirror.Ids(), (std::vector<Id>{ids[0], ids[2], ids[3], ids[4]}));
  ExpectSameAnswers(writer, mirror, words);

  map.ClearClientData();  // a reset
  writer.Clear();
  const Id after_reset = map.AddKeyframe(FrameWithWords(words[1])).id;
  writer.Add(after_reset, words[1]);
  SyncDatabaseWithMap(map, &mirror);
  EXPECT_EQ(mirror.Ids(), std::vector<Id>{after_reset});
  ExpectSameAnswers(writer, mirror, words);
}

}  // namespace
}  // namespace lcv::slam
