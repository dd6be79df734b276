#pragma once
// The visibility attack: a line's hidden point was seen by the server keyframes that list the
// line, so it lies in the part of the line inside all their view frusta. Per keyframe the
// feasible set is {s : the point L(s) projects inside the image (camera model, distortion
// included) and its distance to the camera centre is in [near, far]}; the attack intersects these
// sets over the keyframes, estimates the point as the midpoint of the resulting interval and
// scores risk = min(1, 2 tau / length): the probability that the midpoint is within tau of the
// point if the point is uniform on the interval.
//
// Keyframes are taken in id order; each one refines the interval so far: its distance range is
// solved in closed form (a quadratic in s), clipped to the interval so far, and the in-image
// part found by sampling that range and bisecting the two ends of the visible run (assumed one
// interval: exact for a pinhole frustum, which is convex). A keyframe that sees none of the
// interval so far is skipped as inconsistent.
// Keyframes come from LineLandmark::server_keyframe_ids, plus ServerKeyframe::line_ids.

#include "privacy/attack_result.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct VisibilityAttackOptions {
  double near_m = 0.0;   // minimum distance from a camera centre
  // Maximum distance from a camera centre; <= 0: the diagonal of the scene box estimated from
  // the lines (EstimateSceneBox), a bound every point of the scene respects.
  double far_m = 0.0;
  // tau of the risk score; <= 0: 1% of the scene box diagonal.
  double risk_tolerance_m = 0.0;
  int samples_per_keyframe = 24;
  int num_threads = 0;
};

// Lines seen by no keyframe get no estimate and risk 0. Lines whose frusta do not overlap (noisy
// poses) get no estimate either.
LineAttackResult RunVisibilityAttack(const slam::Map& map,
                                     const VisibilityAttackOptions& options = {});

}  // namespace lcv::privacy
