#include "slam/match/projection_matcher.h"

#include <gtest/gtest.h>

#include "tests/slam/match/matcher_test_util.h"

namespace lcv::slam {
namespace {

class ProjectionMatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = MakeCamera(testing::SyntheticPinhole());
    scene_ = testing::MakeSlabScene(1500, -3.0, 3.0, 4.0, 9.0, seed_);
    pose_ = testing::MakeLateralTrajectory(5, 0.1)[4];
    std::mt19937_64 rng(seed_ + 1);
    testing::ObservationNoise noise;
    noise.clutter = 200;
    observed_ = testing::ObserveScene(scene_, *camera_, pose_, noise, &rng);
    frame_ = testing::MakeFrame(*camera_, observed_, pose_, 1);
    for (size_t j = 0; j < scene_.points_in_world.size(); ++j) {
      ProjectionCandidate c;
      c.landmark_id = 1000 + j;
      c.position_in_world = scene_.points_in_world[j];
      c.descriptor = scene_.descriptors[j];
      c.radius_px = 10.f;
      c.reference_angle_deg = 0.f;
      candidates_.push_back(c);
    }
  }
  // Correct and wrong matches in frame_.
  std::pair<int, int> Score() const {
    int correct = 0, wrong = 0;
    for (int i = 0; i < frame_.num_keypoints(); ++i) {
      if (frame_.landmark_ids[i] == kInvalidId) continue;
      const int j = static_cast<int>(frame_.landmark_ids[i] - 1000);
      (observed_.point_index[i] == j ? correct : wrong)++;
    }
    return {correct, wrong};
  }

  const std::uint64_t seed_ = 31;
  std::unique_ptr<Camera> camera_;
  testing::SyntheticScene scene_;
  Rigid3d pose_;
  testing::SyntheticFrame observed_;
  Frame frame_;
  std::vector<ProjectionCandidate> candidates_;
  ProjectionMatchScratch scratch_;
};

TEST_F(ProjectionMatcherTest, FindsTheTrueMatchesFromAPerturbedPose) {
  SCOPED_TRACE("seed " + std::to_string(seed_));
  // A pose 2 cm and 0.2 degrees off: projections move by a few pixels.
  Vector6d delta;
  delta << 0.02, -0.01, 0.0, 0.002, -0.003, 0.001;
  const Rigid3d perturbed = Rigid3d::Exp(delta) * pose_;
  const int matches = MatchByProjection(candidates_, perturbed, ProjectionMatchOptions(), &frame_, &scratch_);
  const auto [correct, wrong] = Score();
  EXPECT_EQ(matches, correct + wrong);
  int visible = 0;
  for (const int j : observed_.point_index) visible += j >= 0;
  EXPECT_GE(correct, 0.95 * visible) << correct << " of " << visible;
  EXPECT_LE(wrong, 0.01 * matches);
}

TEST_F(ProjectionMatcherTest, SkipsKeypointsThatAlreadyHaveALandmark) {
  for (int i = 0; i < frame_.num_keypoints(); ++i) frame_.landmark_ids[i] = 5;
  EXPECT_EQ(MatchByProjection(candidates_, pose_, ProjectionMatchOptions(), &frame_, &scratch_), 0);
  // Outliers may be re-matched.
  for (int i = 0; i < frame_.num_keypoints(); ++i) frame_.is_outlier[i] = 1;
  EXPECT_GT(MatchByProjection(candidates_, pose_, ProjectionMatchOptions(), &frame_, &scratch_), 0);
}

TEST_F(ProjectionMatcherTest, OctaveBandAndRadiusAreHonoured) {
  for (auto& c : candidates_) {
    c.min_octave = 1;  // every synthetic keypoint is octave 0
    c.max_octave = 3;
  }
  EXPECT_EQ(MatchByProjection(candidates_, pose_, ProjectionMatchOptions(), &frame_, &scratch_), 0);
  for (auto& c : candidates_) {
    c.min_octave = 0;
    c.max_octave = -1;
    c.radius_px = 1.f;  // below the offset applied next
  }
  Vector6d delta = Vector6d::Zero();
  delta(0) = 0.1;  // 10 cm sideways at 4-9 m: > 5 px
  EXPECT_LT(MatchByProjection(candidates_, Rigid3d::Exp(delta) * pose_, ProjectionMatchOptions(),
                              &frame_, &scratch_),
            20);
}

TEST_F(ProjectionMatcherTest, OrientationCheckRejectsInconsistentRotations) {
  // One candidate in 20 claims its reference keypoint was rotated by 90 degrees: a rotation
  // bin holding < 10% of the dominant one is rejected.
  for (size_t j = 0; j < candidates_.size(); j += 20) candidates_[j].reference_angle_deg = 90.f;
  ProjectionMatchOptions options;
  MatchByProjection(candidates_, pose_, options, &frame_, &scratch_);
  for (int i = 0; i < frame_.num_keypoints(); ++i) {
    if (frame_.landmark_ids[i] == kInvalidId) continue;
    EXPECT_NE((frame_.landmark_ids[i] - 1000) % 20, 0u) << "inconsistent rotation kept";
  }
  frame_.ResetMatches();
  options.check_orientation = false;
  MatchByProjection(candidates_, pose_, options, &frame_, &scratch_);
  int rotated = 0;
  for (int i = 0; i < frame_.num_keypoints(); ++i) {
    if (frame_.landmark_ids[i] != kInvalidId) rotated += (frame_.landmark_ids[i] - 1000) % 20 == 0;
  }
  EXPECT_GT(rotated, 10);
}

// The search grid of free keypoints and the worker threads are speed-ups only: the matches are
// those of the frame's own grid, bit for bit, ties between equal descriptors included.
TEST_F(ProjectionMatcherTest, SearchGridAndThreadsKeepTheFrameGridsMatches) {
  // Ties: every fourth keypoint gets its neighbour's descriptor; some keypoints already hold a
  // landmark (skipped) or an outlier's (searched again).
  for (int i = 0; i + 1 < frame_.num_keypoints(); i += 4) {
    frame_.descriptors[i] = frame_.descriptors[i + 1];
  }
  for (int i = 2; i < frame_.num_keypoints(); i += 9) {
    frame_.landmark_ids[i] = 1;
    frame_.is_outlier[i] = (i % 2) != 0;
  }
  const Frame start = frame_;
  Vector6d delta;
  delta << 0.03, -0.02, 0.01, 0.003, -0.002, 0.001;
  const Rigid3d perturbed = Rigid3d::Exp(delta) * pose_;
  for (ProjectionCandidate& c : candidates_) c.radius_px = 25.f;  // crowded windows
  for (const bool tracking_last_frame : {true, false}) {
    ProjectionMatchOptions reference_options;
    reference_options.ratio = tracking_last_frame ? 1.f : 0.8f;
    reference_options.check_orientation = tracking_last_frame;
    reference_options.search_cell_px = 0;
    frame_ = start;
    const int reference_matches =
        MatchByProjection(candidates_, perturbed, reference_options, &frame_, &scratch_);
    const std::vector<Id> reference = frame_.landmark_ids;
    EXPECT_GT(reference_matches, 100);
    for (const auto& [cell_px, threads] :
         std::vector<std::pair<int, int>>{{8, 1}, {8, 2}, {5, 3}, {13, 2}}) {
      SCOPED_TRACE("cell " + std::to_string(cell_px) + " px, " + std::to_string(threads) +
                   " threads, " + (tracking_last_frame ? "last frame" : "local map"));
      ProjectionMatchOptions options = reference_options;
      options.search_cell_px = cell_px;
      options.num_threads = threads;
      frame_ = start;
      ProjectionMatchScratch scratch;
      EXPECT_EQ(MatchByProjection(candidates_, perturbed, options, &frame_, &scratch),
                reference_matches);
      EXPECT_EQ(frame_.landmark_ids, reference);
    }
  }
}

TEST(RotationHistogramTest, BinsAndDominantBins) {
  EXPECT_EQ(RotationBin(10.f, 10.f, 30), 0);
  EXPECT_EQ(RotationBin(350.f, 10.f, 30), 2);   // +20 degrees
  EXPECT_EQ(RotationBin(10.f, 358.f, 30), 29);  // -12 degrees = 348
  std::vector<std::vector<int>> bins(30);
  bins[3].assign(100, 0);
  bins[4].assign(40, 0);
  bins[10].assign(20, 0);
  bins[11].assign(5, 0);  // < 10% of the largest: dropped though among the top... not top 3
  const auto keep = DominantRotationBins(bins);
  EXPECT_TRUE(keep[3] && keep[4] && keep[10]);
  EXPECT_FALSE(keep[11]);
  bins[4].assign(9, 0);  // < 10% of 100
  const auto keep2 = DominantRotationBins(bins);
  EXPECT_TRUE(keep2[3] && keep2[10]);
  EXPECT_FALSE(keep2[4]);
}

}  // namespace
}  // namespace lcv::slam
