#include "mapping/io/frame_selection.h"

#include <gtest/gtest.h>

namespace lcv::mapping {
namespace {

std::vector<std::size_t> Select(const std::string& text, std::size_t count) {
  std::string error;
  const auto selection = FrameSelection::Parse(text, &error);
  EXPECT_TRUE(selection) << text << ": " << error;
  return selection ? selection->Apply(count) : std::vector<std::size_t>{};
}

TEST(FrameSelectionTest, PythonSliceSemantics) {
  EXPECT_EQ(Select(":", 4), (std::vector<std::size_t>{0, 1, 2, 3}));
  EXPECT_EQ(Select("1::2", 7), (std::vector<std::size_t>{1, 3, 5}));
  EXPECT_EQ(Select("0::2", 7), (std::vector<std::size_t>{0, 2, 4, 6}));
  EXPECT_EQ(Select("2:5", 10), (std::vector<std::size_t>{2, 3, 4}));
  EXPECT_EQ(Select("2:9:3", 100), (std::vector<std::size_t>{2, 5, 8}));
  EXPECT_EQ(Select("5:100", 7), (std::vector<std::size_t>{5, 6}));  // end clamped
  EXPECT_TRUE(Select("10:", 7).empty());
  EXPECT_TRUE(Select("3:3", 7).empty());
  EXPECT_EQ(Select("::3", 7), (std::vector<std::size_t>{0, 3, 6}));
}

TEST(FrameSelectionTest, OddEvenSplitOfKitti00IsAPartition) {
  const auto odd = Select("1::2", 160);
  const auto even = Select("0::2", 160);
  EXPECT_EQ(odd.size(), 80u);
  EXPECT_EQ(even.size(), 80u);
  for (std::size_t k = 0; k < 80; ++k) {
    EXPECT_EQ(even[k], 2 * k);
    EXPECT_EQ(odd[k], 2 * k + 1);
  }
}

TEST(FrameSelectionTest, SeveralSlicesSelectTheirUnionInFrameOrder) {
  // KITTI 00's even frames with a block left out: the camera interrupted for frames 24..79.
  const auto gap = Select("0:24:2,80::2", 160);
  ASSERT_EQ(gap.size(), 12u + 40u);
  EXPECT_EQ(gap[11], 22u);
  EXPECT_EQ(gap[12], 80u);
  EXPECT_EQ(gap.back(), 158u);
  // Out of order and overlapping: each frame once, increasing.
  EXPECT_EQ(Select("6:9, 0:8:3", 20), (std::vector<std::size_t>{0, 3, 6, 7, 8}));
  EXPECT_TRUE(FrameSelection::Parse("5:9,:")->SelectsAll());
  EXPECT_FALSE(FrameSelection::Parse("0:24:2,80::2")->SelectsAll());
}

TEST(FrameSelectionTest, RejectsBadTextWithReason) {
  for (const std::string bad : {"5", "a:b", "1:2:0", "-1:", "1:2:3:4", "1.5:", "", "1::2,",
                                ",1::2", "0:10,x:"}) {
    std::string error;
    EXPECT_FALSE(FrameSelection::Parse(bad, &error)) << bad;
    EXPECT_FALSE(error.empty()) << bad;
  }
  std::string error;
  FrameSelection::Parse("1:2:0", &error);
  EXPECT_NE(error.find("step"), std::string::npos) << error;
  FrameSelection::Parse("x:", &error);
  EXPECT_NE(error.find("'x'"), std::string::npos) << error;
}

TEST(FrameSelectionTest, ToStringRoundTrips) {
  for (const std::string text : {"1::2", "0:100", "3:40:7", "0:", "0:24:2,80::2"}) {
    const auto selection = FrameSelection::Parse(text);
    ASSERT_TRUE(selection);
    const auto again = FrameSelection::Parse(selection->ToString());
    ASSERT_TRUE(again) << selection->ToString();
    EXPECT_EQ(again->Apply(1000), selection->Apply(1000)) << text;
  }
  EXPECT_TRUE(FrameSelection::Parse(":")->SelectsAll());
  EXPECT_FALSE(FrameSelection::Parse("1::2")->SelectsAll());
  EXPECT_EQ(FrameSelection::Parse("1::2")->ToString(), "1::2");
  EXPECT_EQ(FrameSelection::Parse("0:100:1")->ToString(), "0:100");
  EXPECT_EQ(FrameSelection::Parse("0:24:2, 80::2")->ToString(), "0:24:2,80::2");
}

}  // namespace
}  // namespace lcv::mapping
