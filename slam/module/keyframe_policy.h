#pragma once
// When tracking hands a frame to local mapping as a new keyframe (ORB-SLAM's
// NeedNewKeyframe, monocular): after max_frames frames, or after min_frames frames while mapping
// is idle, provided the frame tracks fewer than tracked_ratio of the reference keyframe's landmarks
// and still at least min_tracked (a frame that tracks almost everything adds nothing; one that
// tracks too little would make a bad keyframe). A frame tracking very few points forces a
// keyframe whenever mapping can take it, so that the map keeps up with fast motion.

namespace lcv::slam {

struct KeyframePolicyOptions {
  int min_frames = 0;   // frames since the last keyframe before one may be inserted
  int max_frames = 10;  // frames since the last keyframe after which one is due (~fps)
  double tracked_ratio = 0.9;
  int min_tracked = 15;
  // Below this many tracked landmarks a keyframe is inserted as soon as mapping accepts one.
  int weak_tracking = 60;
};

struct KeyframeDecisionInput {
  int frames_since_last_keyframe = 0;
  int num_tracked = 0;            // inlier landmark matches of the current frame
  int reference_num_tracked = 0;  // landmarks of the reference keyframe (>= 3 observations)
  bool mapping_idle = true;       // local mapping accepts a keyframe now
};

bool NeedNewKeyframe(const KeyframeDecisionInput& input, const KeyframePolicyOptions& options);

}  // namespace lcv::slam
