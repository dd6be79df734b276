#include "slam/module/keyframe_policy.h"

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

// In a line cloud the client's own points may be out of view (after an interruption, the
// rendered overlap clients came back tracking 40-70 X' and lines and no X): the keyframe there
// restores X' and triangulates new points, so X' and line matches count toward min_tracked.
TEST(KeyframePolicyTest, LineCloudMatchesCountTowardTheMinimumOnly) {
  KeyframePolicyOptions options;
  options.min_tracked = 15;
  options.weak_tracking = 60;
  KeyframeDecisionInput input;
  input.reference_num_tracked = 120;
  input.frames_since_last_keyframe = 3;
  input.registered_in_line_cloud = true;
  input.num_tracked = 0;  // no point X
  input.num_line_cloud_tracked = 0;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.num_line_cloud_tracked = 50;  // weak in X, enough in all
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  // The ratios still judge X alone: a frame that tracks most of its reference's X needs no
  // keyframe however many lines it matched.
  input.num_tracked = 115;
  input.num_line_cloud_tracked = 400;
  input.mapping_idle = true;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
}

TEST(KeyframePolicyTest, FollowsTheTrackedShareAndTheInterval) {
  KeyframePolicyOptions options;
  options.min_frames = 2;
  options.max_frames = 10;
  options.tracked_ratio = 0.9;
  options.min_tracked = 15;
  options.weak_tracking = 60;
  KeyframeDecisionInput input;
  input.reference_num_tracked = 300;
  input.num_tracked = 290;  // tracks nearly everything: never a keyframe
  input.frames_since_last_keyframe = 50;
  EXPECT_FALSE(NeedNewKeyframe(input, options));

  input.num_tracked = 200;  // < 90% of the reference
  input.frames_since_last_keyframe = 1;
  input.mapping_idle = true;
  EXPECT_FALSE(NeedNewKeyframe(input, options));  // too soon
  input.frames_since_last_keyframe = 2;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.mapping_idle = false;
  EXPECT_FALSE(NeedNewKeyframe(input, options));  // mapping busy, not due
  input.frames_since_last_keyframe = 10;
  EXPECT_TRUE(NeedNewKeyframe(input, options));   // due

  input.num_tracked = 140;  // < 50% of the reference: weak, insert even while mapping is busy
  input.frames_since_last_keyframe = 1;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.num_tracked = 40;  // weak: insert even while mapping is busy
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.num_tracked = 10;  // too few to make a good keyframe
  EXPECT_FALSE(NeedNewKeyframe(input, options));
}

// A frame whose pose the constant-velocity model did not find after a tracked frame (a sharp
// turn) is a keyframe at once: not due, mapping busy, and tracking most of the reference.
TEST(KeyframePolicyTest, FailedMotionModelInsertsAKeyframeAtOnce) {
  KeyframePolicyOptions options;
  options.min_frames = 2;
  options.max_frames = 10;
  options.min_tracked = 15;
  KeyframeDecisionInput input;
  input.reference_num_tracked = 100;
  input.num_tracked = 95;
  input.frames_since_last_keyframe = 1;
  input.mapping_idle = false;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.motion_model_failed = true;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.num_tracked = 10;  // still too few to make a good keyframe
  EXPECT_FALSE(NeedNewKeyframe(input, options));
}

// A pose from the two-view step (slam/tracking.h) is a keyframe however few map points it
// tracks: its new points (triangulated by local mapping with the keyframe it was tracked
// against) are what the next frames need.
TEST(KeyframePolicyTest, TwoViewPoseIsAKeyframeWhateverItTracks) {
  KeyframePolicyOptions options;
  options.min_tracked = 15;
  KeyframeDecisionInput input;
  input.reference_num_tracked = 100;
  input.frames_since_last_keyframe = 1;
  input.mapping_idle = false;
  input.motion_model_failed = true;
  input.num_tracked = 4;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.two_view = true;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.num_tracked = 0;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
}

// A frame that moved a fifth of the scene distance away from the reference keyframe is a
// keyframe even when it tracks nearly all the reference's well-observed points (young points
// with 2 observations are not counted) and mapping is busy; still not with too few points.
TEST(KeyframePolicyTest, TravelBeyondAShareOfTheSceneDistanceInsertsAKeyframe) {
  KeyframePolicyOptions options;
  options.max_frames = 10;
  options.min_tracked = 15;
  options.max_travel_of_depth = 0.2;
  KeyframeDecisionInput input;
  input.reference_num_tracked = 100;
  input.num_tracked = 95;
  input.frames_since_last_keyframe = 3;
  input.mapping_idle = false;
  input.travel_of_depth = 0.19;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.travel_of_depth = 0.21;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.travel_of_depth = 0.0;  // unknown (a reference without points): the other rules decide
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.travel_of_depth = 0.5;
  options.max_travel_of_depth = 0.0;  // disabled
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  options.max_travel_of_depth = 0.2;
  input.num_tracked = 10;  // too few to make a good keyframe
  EXPECT_FALSE(NeedNewKeyframe(input, options));
}

// A client registered in a line cloud has a travel rule of its own (shorter by default): the
// same frame is a keyframe there and not in a point map.
TEST(KeyframePolicyTest, ARegisteredLineCloudClientUsesItsOwnTravel) {
  KeyframePolicyOptions options;
  options.max_travel_of_depth = 0.3;
  options.max_travel_of_depth_in_line_cloud = 0.1;
  KeyframeDecisionInput input;
  input.reference_num_tracked = 100;
  input.num_tracked = 95;
  input.frames_since_last_keyframe = 3;
  input.travel_of_depth = 0.15;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.registered_in_line_cloud = true;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.travel_of_depth = 0.09;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  options.max_travel_of_depth_in_line_cloud = 0.0;  // 0: the common rule
  input.travel_of_depth = 0.15;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.travel_of_depth = 0.31;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
}

// A camera that moves further than the travel share in one frame: the travel rule alone does not
// make the very next frame a keyframe too (travel_min_frames); the other rules still may.
TEST(KeyframePolicyTest, TravelWaitsItsMinimumIntervalAfterAKeyframe) {
  KeyframePolicyOptions options;
  options.max_travel_of_depth = 0.1;
  options.travel_min_frames = 2;
  KeyframeDecisionInput input;
  input.reference_num_tracked = 100;
  input.num_tracked = 95;
  input.travel_of_depth = 0.12;
  input.frames_since_last_keyframe = 1;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.frames_since_last_keyframe = 2;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  // The next frame of a keyframe that tracks little is still one (the tracked-share rule).
  input.frames_since_last_keyframe = 1;
  input.num_tracked = 40;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  // 1: any frame.
  input.num_tracked = 95;
  options.travel_min_frames = 1;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
}

// A client leaving the line cloud: its frame tracks fewer X' and lines than its reference
// keyframe observes, while its own points still look well tracked. Below the fading share the
// frame is a keyframe (when mapping allows); not outside a line cloud, not for a reference with
// too few X' to judge by, and not while the share holds.
TEST(KeyframePolicyTest, AFadingLineCloudMakesAKeyframe) {
  KeyframePolicyOptions options;
  options.line_cloud_fading_ratio = 0.85;
  options.line_cloud_fading_min = 30;
  KeyframeDecisionInput input;
  input.registered_in_line_cloud = true;
  input.frames_since_last_keyframe = 3;
  input.reference_num_tracked = 100;
  input.num_tracked = 95;  // the client's own points: no keyframe on their account
  input.reference_num_restored = 100;
  input.num_line_cloud_tracked = 90;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.num_line_cloud_tracked = 80;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.mapping_idle = false;  // busy mapping and not due: wait, as for the client's own points
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.frames_since_last_keyframe = options.max_frames;
  EXPECT_TRUE(NeedNewKeyframe(input, options));
  input.mapping_idle = true;
  input.frames_since_last_keyframe = 3;
  input.registered_in_line_cloud = false;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.registered_in_line_cloud = true;
  input.sees_all_around = true;  // a 360-degree camera keeps the cloud behind it in view
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.sees_all_around = false;
  input.reference_num_restored = 29;  // too few X' in the reference to judge the fading
  input.num_line_cloud_tracked = 10;
  EXPECT_FALSE(NeedNewKeyframe(input, options));
  input.reference_num_restored = 100;
  options.line_cloud_fading_ratio = 0.0;  // off
  EXPECT_FALSE(NeedNewKeyframe(input, options));
}

}  // namespace
}  // namespace lcv::slam
