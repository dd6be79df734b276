// The line-cloud check's rule (LineCloudCheckRefuses, slam/tracking.h): an independent p6L
// localization refuses a tracked pose only when it is confident and disagrees both in its matches
// and in its pose. The numbers are the cases measured in docs/slam.md "Interruptions in a line
// cloud".
#include <cmath>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "slam/tracking.h"

namespace lcv::slam {
namespace {

// A camera at centre c (world), looking along +z turned by yaw_deg about y.
Rigid3d CameraAt(const Eigen::Vector3d& center, double yaw_deg = 0.0) {
  const Eigen::Quaterniond world_from_cam(
      Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()));
  return Rigid3d(world_from_cam, center).Inverse();
}

LineCloudPoseCheckResult Check(const Rigid3d& pose, int inliers, int agreeing) {
  return LineCloudPoseCheckResult{pose, inliers, agreeing};
}

TEST(LineCloudCheck, HasATimeBudgetOnlyOnLiveInput) {
  SystemOptions options;
  EXPECT_EQ(LineCloudCheckTimeBudget(options, 0.1), 0.0);  // recorded input: no limit
  options.live = true;
  EXPECT_DOUBLE_EQ(LineCloudCheckTimeBudget(options, 1.0 / 30.0), 1.0 / 30.0);  // one period
  EXPECT_DOUBLE_EQ(LineCloudCheckTimeBudget(options, 0.0), 0.1);  // before the second frame
  options.tracking.line_cloud_check_live_periods = 2.5;
  EXPECT_DOUBLE_EQ(LineCloudCheckTimeBudget(options, 0.2), 0.5);
  options.tracking.line_cloud_check_live_periods = 0.0;  // switched off
  EXPECT_EQ(LineCloudCheckTimeBudget(options, 0.2), 0.0);
}

TEST(LineCloudCheck, ACheckCutShortIsRetriedOnTheNextFramesAtMostTheirNumber) {
  const int max_retries = 4;
  // An answered check owes nothing, first or retried.
  EXPECT_EQ(LineCloudCheckRetriesLeft(0, false, false, max_retries), 0);
  EXPECT_EQ(LineCloudCheckRetriesLeft(3, true, false, max_retries), 0);
  // Cut short without an answer: the next 4 tracked frames are checked, then no more.
  int left = LineCloudCheckRetriesLeft(0, false, true, max_retries);
  int retries = 0;
  while (left > 0) {
    left = LineCloudCheckRetriesLeft(left, /*was_retry=*/true, /*unanswered=*/true, max_retries);
    ++retries;
  }
  EXPECT_EQ(retries, max_retries);
  // Switched off: none.
  EXPECT_EQ(LineCloudCheckRetriesLeft(0, false, true, 0), 0);
}

TEST(LineCloudCheck, RefusesOnlyWhenMatchesAndPoseBothDisagree) {
  const TrackingSettings settings;  // agreement 0.75, depth share 0.25, 10 deg, 30 inliers
  const Rigid3d tracked = CameraAt(Eigen::Vector3d(0.0, 0.0, 0.0));
  const double depth = 22.5;
  // The camera that jumped: 34 of 68 fit, p6L 8.5 m away and turned 9.6 degrees.
  const Rigid3d elsewhere = CameraAt(Eigen::Vector3d(0.0, 0.0, 8.5), 9.6);
  EXPECT_TRUE(LineCloudCheckRefuses(Check(elsewhere, 68, 34), tracked, depth, settings));
  // Matches that fit (67 of 68): kept, wherever p6L put its own pose.
  EXPECT_FALSE(LineCloudCheckRefuses(Check(elsewhere, 68, 67), tracked, depth, settings));
  // A near pose (fisheye: p6L 2.0 m and 5 degrees off a correct pose, depth 10.9 m, 40 of 61):
  // kept although its matches fit poorly.
  EXPECT_FALSE(LineCloudCheckRefuses(Check(CameraAt(Eigen::Vector3d(2.0, 0.0, 0.0), 5.0), 61, 40),
                                     tracked, 10.9, settings));
  // Too few inliers to contradict anything.
  EXPECT_FALSE(LineCloudCheckRefuses(Check(elsewhere, 29, 0), tracked, depth, settings));
}

TEST(LineCloudCheck, ATurnAloneIsADisagreementOfThePose) {
  const TrackingSettings settings;
  const Rigid3d tracked = CameraAt(Eigen::Vector3d::Zero());
  const Rigid3d turned = CameraAt(Eigen::Vector3d::Zero(), 30.0);
  EXPECT_TRUE(LineCloudCheckRefuses(Check(turned, 50, 10), tracked, 20.0, settings));
  // Without a median depth the distance is not judged, the angle still is.
  EXPECT_TRUE(LineCloudCheckRefuses(Check(turned, 50, 10), tracked, 0.0, settings));
  EXPECT_FALSE(LineCloudCheckRefuses(Check(CameraAt(Eigen::Vector3d(0.0, 0.0, 50.0)), 50, 10),
                                     tracked, 0.0, settings));
}

}  // namespace
}  // namespace lcv::slam
