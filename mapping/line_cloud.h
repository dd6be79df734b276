#pragma once
// Point map -> line cloud: the publishing step (paper Sec. 3.4; Speciale et al. CVPR 2019).
//
// Each point landmark X becomes a line landmark with the same id (coincident points first become
// one point, see LineCloudOptions::coincident_distance):
// - direction d drawn uniformly on the unit sphere from the seeded RNG, independent of the scene;
// - information Omega_L (LineInformationRule): by default the paper's eq. (1) evaluated at a
//   proxy point that the published line and server keyframes determine (SetProxyInformation);
//   eq. (1) from the point's own covariance only when asked, because it reveals where on the
//   line X is (see LineInformationRule);
// - anchor re-drawn as the point of the line closest to the map origin, a function of the line
//   alone, so it carries no information about where on the line X was;
// - descriptor kept; server-keyframe visibility = the keyframes that observed X.
// Client keyframes become server keyframes (pose and line ids only): every keypoint coordinate,
// descriptor list and observation is dropped. Restored points X' are dropped. Existing lines are
// kept (their restored points and client observations dropped; the keyframes that observed them
// join their visibility; their anchors are re-drawn by the same rule, which leaves an anchor
// already drawn by it unchanged). Visibility is made symmetric: a line lists exactly the server
// keyframes whose line_ids contain it, both sorted by id.
//
// Directions are drawn in point-id order from std::mt19937_64(seed): the same map and seed give
// the same line cloud. Never publish the same points twice with different seeds (or after
// re-drawing directions): two lines through one point intersect at it.
// Precondition: ids unique map-wide (as ValidateMap checks); checked, std::logic_error.

#include <cstdint>

#include "slam/data/map.h"

namespace lcv::mapping {

// Where a published line's Omega_L comes from.
// - kProxyPoint (default): eq. (1) of the paper applied to a proxy of X that the published file
//   already determines, never to X itself:
//     X~ = the point of the line closest to the centres C_k of its server keyframes (the foot of
//          the perpendicular from their mean);
//     Sigma~ = (sum_k (I - b_k b_k^T) / (rho_k a_k)^2 + I / rho_max^2)^-1, b_k the unit ray
//          C_k -> X~, rho_k = max(|X~ - C_k|, floor), a_k one pixel's angle of k's camera
//          (PixelAngle), rho_max the largest rho_k (a weak prior that keeps Sigma~ finite);
//     Omega_L = pinv((I - d d^T) Sigma~ (I - d d^T)).
//   This is the first-order covariance of a point triangulated from those keyframes with one
//   pixel of noise (bearing form, so every camera model works the same), at X~: it keeps eq.
//   (1)'s shape (weak along the viewing rays when the baseline is short), its growth with
//   distance and its sqrt(number of views), and uses only published data. The floor,
//   kProxyDistanceFloor x the map's median |X~ - C_k|, stops a line through a camera centre
//   from getting infinite information. Lines no keyframe sees get an isotropic sigma of one
//   pixel at the floor distance. The floor makes the rule a function of the whole map: after
//   dropping lines, SetProxyInformation again (`lcv map publish` and `--mitigate` do).
// - kPointCovariance: eq. (1) from the point's own Sigma_X. Sigma_X grows with the point's
//   distance from the cameras that triangulated it, so its size says how far X is from one of
//   the line's server keyframes, and the line meets that sphere in at most two points:
//   privacy/information_attack.h recovered 38.8% of a synthetic street's points within 5 cm
//   from it (docs/audit.md, "The information attack"). For reproducing the paper only.
enum class LineInformationRule { kProxyPoint, kPointCovariance };
inline constexpr double kProxyDistanceFloor = 0.25;

struct LineCloudOptions {
  std::uint64_t seed = 0;
  LineInformationRule information = LineInformationRule::kProxyPoint;
  // Coincident points are merged before lines are drawn: two lines through one point cross
  // exactly there and reveal it (a COLMAP model of a street has ~5% of its points within a
  // millimetre of another). Points closer than coincident_distance (map units; < 0: 5e-5 x the
  // median distance of the points from their median, robust to far points; 0: off) become one line: the smallest id is kept,
  // at the points' mean, with the information-weighted covariance
  // (sum_i Sigma_i^-1)^-1, the union of their keyframes, the kept point's descriptor.
  double coincident_distance = -1.0;
};

struct LineCloudReport {
  int coincident_groups = 0;   // groups of coincident points found
  int points_merged_away = 0;  // points folded into another (no line of their own)
};

// Sets every line's Omega_L of map by the kProxyPoint rule (LineInformationRule), from the
// lines, server keyframes and cameras of map. Used by ConvertToLineCloud; callable on any line
// cloud (re-publishing one made with kPointCovariance).
void SetProxyInformation(slam::Map* map);

// After lines were dropped from a cloud converted with options: sets the kProxyPoint rule again
// (its floor is a median over the lines); nothing for kPointCovariance (no points to use).
void ReapplyInformationRule(const LineCloudOptions& options, slam::Map* map);

// kProxyPoint's floor of the keyframe-to-proxy distance for map (1 when no line is seen).
double ProxyDistanceFloor(const slam::Map& map);

// kProxyPoint's Omega_L of one line of map with the given floor (ProxyDistanceFloor(map)).
Eigen::Matrix3d ProxyLineInformation(const slam::Map& map, const slam::LineLandmark& line,
                                     double distance_floor);

slam::Map ConvertToLineCloud(const slam::Map& point_map, const LineCloudOptions& options,
                             LineCloudReport* report = nullptr);

// The point map with coincident points merged as described in LineCloudOptions (distance > 0,
// map units); observations of merged points move to the kept one. For tests and the publisher.
slam::Map MergeCoincidentPoints(const slam::Map& point_map, double distance,
                                LineCloudReport* report = nullptr);

}  // namespace lcv::mapping
