#include "slam/data/frame_anchor.h"

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam {
namespace {

// Keyframes without features at known poses (the first is the map's root).
class FrameAnchorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = MakeCamera(testing::SyntheticPinhole());
    for (int k = 0; k < 3; ++k) {
      Frame frame;
      frame.id = k;
      frame.camera = camera_.get();
      frame.cam_from_world = Rigid3d(ExpSO3(Eigen::Vector3d(0.0, 0.2 * k, 0.0)),
                                     Eigen::Vector3d(-0.8 * k, 0.1, 0.3 * k));
      PrepareFrame(&frame);
      ids_.push_back(map_.AddKeyframe(frame).id);
    }
    // A frame tracked against keyframe 1.
    frame_ = Rigid3d(ExpSO3(Eigen::Vector3d(0.05, 0.3, 0.0)), Eigen::Vector3d(-1.1, 0.2, 0.6));
    frame_from_reference_ = frame_ * map_.keyframes().at(ids_[1]).cam_from_world.Inverse();
  }
  // The frame's pose in a world scaled by `scale` about the origin.
  Rigid3d ScaledFrame(double scale) const {
    return Rigid3d(frame_.rotation, scale * frame_.translation);
  }

  std::unique_ptr<Camera> camera_;
  SlamMap map_;
  std::vector<Id> ids_;
  Rigid3d frame_, frame_from_reference_;
};

void ExpectSamePose(const Rigid3d& a, const Rigid3d& b) {
  EXPECT_LT((a.translation - b.translation).norm(), 1e-9);
  EXPECT_LT(a.rotation.angularDistance(b.rotation), 1e-9);
}

TEST_F(FrameAnchorTest, LivingReferenceGivesTheRecordedPose) {
  const std::optional<Rigid3d> pose = AnchoredFramePose(map_, ids_[1], frame_from_reference_, 1.0);
  ASSERT_TRUE(pose);
  ExpectSamePose(*pose, frame_);
}

TEST_F(FrameAnchorTest, OffsetFollowsTheKeyframeScale) {
  map_.Transform(2.5);  // every keyframe's scale becomes 2.5
  const std::optional<Rigid3d> pose = AnchoredFramePose(map_, ids_[1], frame_from_reference_, 1.0);
  ASSERT_TRUE(pose);
  ExpectSamePose(*pose, ScaledFrame(2.5));
  // A record made after the rescale (at scale 2.5) is not rescaled again.
  const Rigid3d recorded_later =
      ScaledFrame(2.5) * map_.keyframes().at(ids_[1]).cam_from_world.Inverse();
  ExpectSamePose(*AnchoredFramePose(map_, ids_[1], recorded_later, 2.5), ScaledFrame(2.5));
}

TEST_F(FrameAnchorTest, ErasedReferenceIsFollowedThroughScaleChanges) {
  map_.Transform(2.0);   // before the erasure
  map_.EraseKeyframe(ids_[1]);
  map_.Transform(0.75);  // and after it
  ASSERT_EQ(map_.FindKeyframe(ids_[1]), nullptr);
  const std::optional<Rigid3d> pose = AnchoredFramePose(map_, ids_[1], frame_from_reference_, 1.0);
  ASSERT_TRUE(pose);
  ExpectSamePose(*pose, ScaledFrame(1.5));
}

TEST_F(FrameAnchorTest, UnknownReferenceGivesNothing) {
  EXPECT_FALSE(AnchoredFramePose(map_, 12345, frame_from_reference_, 1.0));
}

// A keyframe candidate tracked in a snapshot, mapped after the writer moved the map (live): it
// enters the map where its offset from the reference puts it today.
TEST_F(FrameAnchorTest, KeyframeCandidateIsReanchoredOnlyWhenTheMapMoved) {
  Frame candidate;
  candidate.cam_from_world = frame_;
  candidate.reference_keyframe_id = ids_[1];
  EXPECT_FALSE(ReanchoredKeyframePose(map_, candidate));  // nothing recorded
  candidate.reference_cam_from_world = map_.keyframes().at(ids_[1]).cam_from_world;
  candidate.reference_scale = map_.keyframes().at(ids_[1]).scale;
  EXPECT_FALSE(ReanchoredKeyframePose(map_, candidate));  // the map as tracked

  map_.Transform(2.5);  // e.g. registered into a line cloud of another scale
  std::optional<Rigid3d> pose = ReanchoredKeyframePose(map_, candidate);
  ASSERT_TRUE(pose);
  ExpectSamePose(*pose, ScaledFrame(2.5));

  map_.EraseKeyframe(ids_[1]);  // and the reference culled meanwhile
  pose = ReanchoredKeyframePose(map_, candidate);
  ASSERT_TRUE(pose);
  ExpectSamePose(*pose, ScaledFrame(2.5));
}

TEST(RescaledOffset, ScalesOnlyTheTranslation) {
  const Rigid3d offset(ExpSO3(Eigen::Vector3d(0.1, 0.0, 0.2)), Eigen::Vector3d(1.0, 2.0, 3.0));
  const Rigid3d rescaled = RescaledOffset(offset, 2.0, 3.0);
  EXPECT_LT((rescaled.translation - 1.5 * offset.translation).norm(), 1e-12);
  EXPECT_LT(rescaled.rotation.angularDistance(offset.rotation), 1e-12);
  ExpectSamePose(RescaledOffset(offset, 0.0, 3.0), offset);  // no recorded scale: unchanged
}

}  // namespace
}  // namespace lcv::slam
