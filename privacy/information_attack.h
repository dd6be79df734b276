#pragma once
// The information attack: reads the hidden point's distance from a line's Omega_L.
//
// Eq. (1) of the paper publishes Omega_L = pinv((I - d d^T) Sigma_X (I - d d^T)). It removes
// what Sigma_X says along d, but not its size: a triangulated point's uncertainty across the
// viewing ray is about one pixel's angle times its distance from the camera that measured it
// (the engine's map files write exactly that; first-order covariances from the tracks, as a
// COLMAP import computes them, are close). So sigma = 1 / sqrt(largest eigenvalue of Omega_L)
// gives the distance r = sigma / pixel_angle from one of the line's server keyframes, and the
// line meets the sphere of radius r about that keyframe's centre in at most two points, one of
// which is the hidden point.
//
// Per line: for each server keyframe k that sees it (id order), the 0-2 points of the line at
// distance sigma / angle_k from C_k; kept only when every keyframe that sees the line images
// the point (in front, inside the image: the visibility attack's test). The estimate is the
// first kept candidate, keyframes in id order (the keyframe that triangulated a point is usually
// the first to see it), the smaller line parameter of its two first; risk = 1 / (number of kept
// candidates), the chance that a uniform pick among them is the right one.
//
// mapping::LineInformationRule::kProxyPoint (the default of `lcv map convert`) makes Omega_L
// from the published line and keyframes alone, which defeats this attack: a line whose Omega_L
// is that rule's (mapping::ProxyLineInformation, relative 1e-9) is skipped, and on other
// published data the candidates are unrelated to the point. The attack shows why the rule is
// the default (docs/audit.md "The information attack") and audits line clouds made with eq. (1)
// from the points' covariances or by other tools.

#include "privacy/attack_result.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct InformationAttackOptions {
  // The attacker's model of the publisher: sigma = distance x angle. <= 0: one pixel's angle of
  // each keyframe's camera (mapping::PixelAngle), the engine's own rule.
  double angle_per_distance = 0.0;
  int num_threads = 0;
};

// Lines with a zero information matrix or seen by no keyframe get no estimate and risk 0.
LineAttackResult RunInformationAttack(const slam::Map& map,
                                      const InformationAttackOptions& options = {});

}  // namespace lcv::privacy
