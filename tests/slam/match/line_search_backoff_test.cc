#include "slam/match/line_search_backoff.h"

#include <vector>

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

// Frames (of the next `frames`) on which the line is searched, each searched frame recorded with
// the given outcome.
std::vector<int> SearchedFrames(LineSearchBackoff* backoff, Id line, int frames,
                                bool in_image = true, bool matched = false) {
  std::vector<int> searched;
  for (int f = 0; f < frames; ++f) {
    backoff->StartFrame();
    if (!backoff->ShouldSearch(line)) continue;
    searched.push_back(f);
    backoff->Record(line, in_image, matched);
  }
  return searched;
}

// `lcv slam`'s setting for an equirectangular camera (the library's default is off).
LineSearchBackoffOptions On() {
  LineSearchBackoffOptions options;
  options.misses = 2;
  return options;
}

TEST(LineSearchBackoffTest, IsOffByDefault) {
  EXPECT_FALSE(LineSearchBackoff().enabled());
  EXPECT_TRUE(LineSearchBackoff(On()).enabled());
}

TEST(LineSearchBackoffTest, AMissingLineIsSearchedOnFewerAndFewerFramesUpToTheLongestPeriod) {
  LineSearchBackoffOptions options;
  options.misses = 2;
  options.max_period = 8;
  LineSearchBackoff backoff(options);
  const Id line = 5;
  EXPECT_EQ(backoff.Period(line), 1);
  const std::vector<int> searched = SearchedFrames(&backoff, line, 64);
  ASSERT_GE(searched.size(), 8u);
  // Two misses at period 1, two at 2, two at 4, then 8 for good.
  std::vector<int> gaps;
  for (size_t i = 1; i < searched.size(); ++i) gaps.push_back(searched[i] - searched[i - 1]);
  // gaps[i] is waited with i + 1 misses: period 1 before 2 misses, 2 before 4, 4 before 6, then
  // 8. A gap is at most its period (the first gap of a new period may be shorter, by the
  // stagger), and exactly the period once the period has stayed the same.
  for (size_t i = 0; i < gaps.size(); ++i) {
    const int misses = static_cast<int>(i) + 1;
    const int period = misses < 2 ? 1 : misses < 4 ? 2 : misses < 6 ? 4 : 8;
    EXPECT_LE(gaps[i], period) << "gap " << i;
    if (misses >= 7) {
      EXPECT_EQ(gaps[i], 8) << "gap " << i;
    }
  }
  EXPECT_EQ(backoff.Period(line), 8);
  // 64 frames: 2 + 2 + 2 searches at periods 1, 2, 4 (the first of a new period may come
  // sooner, by the stagger), then one in 8.
  EXPECT_LE(searched.size(), 14u);
}

TEST(LineSearchBackoffTest, AMatchForgetsTheMisses) {
  LineSearchBackoffOptions options = On();
  options.max_period = 8;
  LineSearchBackoff backoff(options);
  const Id line = 11;
  SearchedFrames(&backoff, line, 40);
  ASSERT_GT(backoff.Period(line), 1);
  // The line's next search matches: searched on every frame again.
  int frame = 0;
  for (; frame < 16; ++frame) {
    backoff.StartFrame();
    if (backoff.ShouldSearch(line)) break;
  }
  ASSERT_LT(frame, 16);
  backoff.Record(line, true, true);
  EXPECT_EQ(backoff.Period(line), 1);
  EXPECT_EQ(backoff.num_lines_missing(), 0);
  EXPECT_EQ(SearchedFrames(&backoff, line, 2, true, true), (std::vector<int>{0, 1}));
}

TEST(LineSearchBackoffTest, ALineOutsideTheImageIsNotCountedAgainst) {
  LineSearchBackoff backoff(On());
  const Id line = 3;
  EXPECT_EQ(SearchedFrames(&backoff, line, 30, /*in_image=*/false).size(), 30u);
  EXPECT_EQ(backoff.Period(line), 1);
  EXPECT_EQ(backoff.num_lines_missing(), 0);
}

TEST(LineSearchBackoffTest, BackedOffLinesAreSpreadOverTheFrames) {
  LineSearchBackoffOptions options;
  options.misses = 1;
  options.max_period = 4;
  LineSearchBackoff backoff(options);
  // 400 lines that never match, all at the longest period after a few frames.
  const int num_lines = 400;
  for (int f = 0; f < 20; ++f) {
    backoff.StartFrame();
    for (Id line = 0; line < num_lines; ++line) {
      if (backoff.ShouldSearch(line)) backoff.Record(line, true, false);
    }
  }
  for (Id line = 0; line < num_lines; ++line) ASSERT_EQ(backoff.Period(line), 4);
  // Each frame searches a quarter of them, not all on one frame and none on the others.
  for (int f = 0; f < 8; ++f) {
    backoff.StartFrame();
    int searched = 0;
    for (Id line = 0; line < num_lines; ++line) searched += backoff.ShouldSearch(line);
    EXPECT_EQ(searched, num_lines / 4);
  }
}

TEST(LineSearchBackoffTest, DisabledSearchesEveryLineOnEveryFrame) {
  for (const auto& [misses, max_period] : {std::pair{0, 8}, std::pair{2, 1}}) {
    LineSearchBackoffOptions options;
    options.misses = misses;
    options.max_period = max_period;
    LineSearchBackoff backoff(options);
    EXPECT_FALSE(backoff.enabled());
    EXPECT_EQ(SearchedFrames(&backoff, 9, 50).size(), 50u);
    EXPECT_EQ(backoff.num_lines_missing(), 0);
  }
}

TEST(LineSearchBackoffTest, ClearForgetsEveryLine) {
  LineSearchBackoff backoff(On());
  SearchedFrames(&backoff, 1, 20);
  SearchedFrames(&backoff, 2, 20);
  ASSERT_EQ(backoff.num_lines_missing(), 2);
  backoff.Clear();
  EXPECT_EQ(backoff.num_lines_missing(), 0);
  EXPECT_EQ(backoff.Period(1), 1);
}

}  // namespace
}  // namespace lcv::slam
