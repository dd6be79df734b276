#pragma once
// Check 3, concealed lines (the paper's Desk experiment, Sec. 5): an object present when the
// server map was built but absent (concealed) in a client's video must not come back through the
// client's map. Given the client's map after LC-VSLAM:
// - no client point X (Map::points) and no restored point X' (LineLandmark::restored_point) inside
//   a concealed region (up to point_region_margin_m) lies within epsilon of a concealed line's part
//   inside that region;
// - every X' has real client observations: at least min_observations observations, each naming
//   an existing client keyframe and keypoint, whose keypoint lies within max_reprojection_px of
//   the projection of X' (the client saw something there; an X' without such support was
//   fabricated from the line).
//
// Concealed lines: the lines (of the published map and of the client map, by id) that cross a
// concealed region's box, the part inside the box being the one checked; with a reference map,
// only the lines whose hidden point lies in the box (fewer false alarms); plus lines listed by id
// (the whole line is checked).
//
// Regions come from a REGIONS.json or a scene.json (privacy/concealed_regions.h).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "privacy/reference_match.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct ConcealedRegion {
  std::string name;
  Eigen::AlignedBox3d box;  // world frame of the maps
  // Faces of the box that rest on an object the client sees (scene.json: the desk under a
  // removed document): rests_min[i] for the face at box.min()[i], rests_max[i] for box.max()[i].
  // Client points there are that object's surface, seen where the concealed object used to
  // stand, so the checked region shrinks by the margin across such a face instead of growing.
  Eigen::Array<bool, 3, 1> rests_min = Eigen::Array<bool, 3, 1>::Constant(false);
  Eigen::Array<bool, 3, 1> rests_max = Eigen::Array<bool, 3, 1>::Constant(false);
};

struct ConcealedSpec {
  std::vector<ConcealedRegion> regions;
  std::vector<slam::Id> line_ids;  // concealed lines given explicitly
};

struct ConcealedCheckOptions {
  double epsilon_m = 0.05;
  // A client point (X or X') is checked against a region's concealed lines only when it lies in
  // the region's box grown by this margin: a point outside the object's box is a point of
  // something else the client saw (the desk under a removed document: `lcv demo` found a desk
  // point 1.9 cm outside the box and 2.1 cm from a concealed line's part inside it). The margin
  // absorbs the client map's triangulation and alignment noise. Negative: any point within
  // epsilon of the lines' parts counts (the box grown by epsilon). Listed line ids (no region)
  // are checked against every point. Across a face that rests on a visible object
  // (ConcealedRegion::rests_min/max) the box shrinks by the margin instead: `lcv demo --seed
  // 1..6` found desk points 0-8 mm above the desk inside or beside a removed document's
  // footprint, 0.8-4.8 cm from concealed lines, in 3 of 6 seeds.
  double point_region_margin_m = 0.01;
  int min_observations = 1;
  double max_reprojection_px = 10.0;
  // A client point X (not an X') near a concealed line is a violation only when its own
  // observations place it there: if a position along its viewing ray (from the centroid of its
  // observing keyframes' centres) that every observation still accepts, within SLAM's 95% gate
  // (chi2 5.991 at sigma = pyramid_scale_factor^octave px), lies outside the checked zone (the
  // region's box with the margin, epsilon around its concealed lines), the point is not evidence
  // of the object. Why: `lcv demo`'s desk client (seed 1, 60 frames) held a desk point seen
  // through where the removed document stood, triangulated from the last two keyframes (5 degrees
  // of parallax) 8 cm short of the desk, inside the document's box and 4 mm from a concealed
  // line; its observations allow it anywhere within about 8 cm along the ray. A point the client
  // really took from the object sits on it however far it may move: well-triangulated points do
  // not move, so their verdict is their position's. Points with fewer than two usable
  // observations, or whose estimate its observations reject (a planted point), are judged by
  // their position alone. false: by position alone always.
  bool clear_points_by_observations = true;
  double pyramid_scale_factor = 1.2;  // of the client's ORB pyramid (the engine's default)
};

struct ConcealedViolation {
  // "point_near_concealed_line", "restored_point_near_concealed_line",
  // "restored_point_without_observations"
  std::string kind;
  slam::Id point_id = slam::kInvalidId;  // point id, or the id of the line holding X'
  slam::Id line_id = slam::kInvalidId;   // the concealed line (kInvalidId for observations)
  std::string region;                    // empty for listed lines / observations
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double distance_m = 0.0;               // to the line
  std::string reason;                    // for observation problems
};

struct ConcealedCheckResult {
  int num_concealed_lines = 0;
  int num_points_checked = 0;
  int num_restored_points_checked = 0;
  // Client points X within epsilon of a concealed line that their observations also allow
  // outside the checked zone (ConcealedCheckOptions::clear_points_by_observations): not
  // violations.
  int num_points_cleared_by_observations = 0;
  std::vector<ConcealedViolation> violations;
  bool passed() const { return violations.empty(); }
};

// published: the line cloud given to the audit (its lines are the server's); client: the client
// map after LC-VSLAM. reference_match (may be null) belongs to published.
ConcealedCheckResult CheckConcealedLines(const slam::Map& published, const slam::Map& client,
                                         const ConcealedSpec& spec,
                                         const ReferenceMatch* reference_match,
                                         const ConcealedCheckOptions& options = {});

}  // namespace lcv::privacy
