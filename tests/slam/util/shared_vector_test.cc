#include "slam/util/shared_vector.h"

#include <gtest/gtest.h>

#include <vector>

#include "slam/data/slam_map.h"

namespace lcv::slam {
namespace {

TEST(SharedVector, CopiesShareUntilOneIsWritten) {
  SharedVector<int> a = std::vector<int>{1, 2, 3};
  SharedVector<int> b = a;
  EXPECT_TRUE(a.SharesBufferWith(b));
  b.push_back(4);  // detaches b first
  EXPECT_FALSE(a.SharesBufferWith(b));
  EXPECT_EQ(a.get(), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(b.get(), (std::vector<int>{1, 2, 3, 4}));
  SharedVector<int> c = a;
  c.mutate()[0] = 7;
  EXPECT_EQ(a[0], 1);
  EXPECT_EQ(c[0], 7);
}

TEST(SharedVector, OverwriteStartsAFreshBufferOnlyWhenShared) {
  SharedVector<int> a = std::vector<int>(100, 5);
  const SharedVector<int> kept = a;
  std::vector<int>& fresh = a.overwrite();
  EXPECT_TRUE(fresh.empty()) << "a shared buffer is not copied for overwriting";
  fresh.assign(3, 9);
  EXPECT_EQ(kept.size(), 100u);
  EXPECT_EQ(a.get(), (std::vector<int>{9, 9, 9}));

  SharedVector<int> alone = std::vector<int>(100, 5);
  const int* before = alone.data();
  std::vector<int>& same = alone.overwrite();
  EXPECT_EQ(same.data(), before) << "an unshared buffer keeps its storage";
}

TEST(SharedVector, ReadsLikeAConstVector) {
  const SharedVector<int> empty;
  EXPECT_TRUE(empty.empty());
  EXPECT_EQ(empty.size(), 0u);
  EXPECT_EQ(empty.begin(), empty.end());
  const std::vector<int>& as_vector = empty;
  EXPECT_TRUE(as_vector.empty());

  const SharedVector<int> v = {4, 5, 6};
  int sum = 0;
  for (const int x : v) sum += x;
  EXPECT_EQ(sum, 15);
  EXPECT_EQ(v.front(), 4);
  EXPECT_EQ(v.back(), 6);
  EXPECT_THROW(v.at(3), std::out_of_range);
  EXPECT_EQ(v, (SharedVector<int>{4, 5, 6}));
}

// What the loop-closing stage's copy of the map costs: a keyframe's features are shared with
// the writer's map, not copied; the copy still reads the same values.
TEST(SharedVector, ACopiedMapSharesItsKeyframesFeatures) {
  Frame frame;
  frame.keypoints = {Keypoint{10.f, 20.f, 0.f, 0}, Keypoint{30.f, 40.f, 90.f, 1}};
  frame.descriptors.resize(2);
  frame.descriptors[1][0] = 7;
  frame.bearings = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX()};
  frame.grid.Build(frame.keypoints, 64, 64, 32);
  frame.bow = {BowEntry{3, 1.0}};
  frame.direct_index = {DirectIndexEntry{2, {0, 1}}};
  SlamMap map;
  const Id id = map.AddKeyframe(frame).id;

  const SlamMap copy = map;
  const SlamKeyframe& original = *map.FindKeyframe(id);
  const SlamKeyframe& copied = *copy.FindKeyframe(id);
  EXPECT_TRUE(copied.keypoints.SharesBufferWith(original.keypoints));
  EXPECT_TRUE(copied.descriptors.SharesBufferWith(original.descriptors));
  EXPECT_TRUE(copied.bearings.SharesBufferWith(original.bearings));
  EXPECT_TRUE(copied.bow.SharesBufferWith(original.bow));
  EXPECT_TRUE(copied.direct_index.SharesBufferWith(original.direct_index));
  EXPECT_EQ(copied.descriptors[1][0], 7);
  std::vector<int> found;
  copied.grid.Query(copied.keypoints, 30.f, 40.f, 2.f, 0, -1, &found);
  EXPECT_EQ(found, std::vector<int>{1});
  // The landmark links are the copy's own.
  EXPECT_NE(copied.landmark_ids.data(), original.landmark_ids.data());
}

}  // namespace
}  // namespace lcv::slam
