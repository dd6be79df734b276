#pragma once
// Check 5, mitigation that keeps localization: drop lines in a given order (the ones the attacks
// recover first) but never below a per-server-keyframe coverage, so that every view of the
// published map keeps enough lines, spread over its image, for p6L (`lcv map publish`,
// docs/curation.md "Publishing gate").
//
// Why per keyframe: a client localizes a frame from the lines its view shares with some server
// keyframe. Dropping the riskiest lines map-wide removes them where the scene is dense (facades
// with many points: exactly where the density attack succeeds) and can leave the views of those
// places with few lines, or with lines in one corner of the image only. The guard measures each
// keyframe's lines where a client sees them, at the image position of their hidden point.
//
// Coverage of a server keyframe k (the lines it lists, at their hidden point's projection):
//  - at least min(n_k, min_lines_per_keyframe) lines, n_k = its lines before the call;
//  - in each cell of an image_grid x image_grid grid, at least min(n_kc, per-cell floor) lines,
//    n_kc = the cell's lines before the call, per-cell floor = ceil(min_lines_per_keyframe /
//    image_grid^2): the keyframe floor spread evenly over the image.
// A line is protected when dropping it would break the coverage of a keyframe that lists it.
//
// Frames: hidden points in the world frame of the map, projected with each server keyframe's
// cam_from_world and camera. Lines without a hidden point (or behind / outside a keyframe's
// image) count toward the keyframe's total but no cell. Thread safety: pure functions of their
// inputs; concurrent calls are fine.

#include <limits>
#include <map>
#include <vector>

#include <Eigen/Core>

#include "privacy/audit.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct KeyframeCoverageOptions {
  // 24 = twice p6L's minimum inliers (12, slam::LineCloudLocalizerOptions): a client frame near
  // a keyframe matches only part of the lines that keyframe saw (viewpoint change, ratio test,
  // one-to-one matching); with half of them matched it still reaches the minimum.
  int min_lines_per_keyframe = 24;
  // 4 x 4 cells: with the floor of 24 lines, 2 lines per cell, so a keyframe keeps bearings over
  // the whole image (a pose from bearings bunched in one part of the image is poorly conditioned:
  // rotation and translation trade off). A coarser grid allows all lines in half the image; a
  // finer one (5 x 5 and up) brings the per-cell floor down to 1 line.
  int image_grid = 4;
};

struct CoverageDropOptions {
  int max_lines = 0;  // lines to drop in this call at most (>= 0)
  KeyframeCoverageOptions coverage;
  bool guard = true;  // false: drop in priority order, coverage ignored
  // When a tier has fewer than the remaining budget of unprotected candidates: also drop its
  // protected candidates (in priority order). The audit's limits come first; the report
  // counts them.
  bool break_coverage_when_short = true;
  // Tiers: candidates with priority >= first_tier_priority form a first tier, dropped (its
  // protected ones included, with break_coverage_when_short) before any other candidate. For
  // lines that must go before the rest whatever the coverage: the lines an attack recovers
  // (RecoveredFirstPriority: 2 + risk), since only they lower the recovered fraction directly;
  // measured on the demo's street at density@1%=0.05, guarding recovered lines behind
  // unrecovered ones spent the whole --max-drop on lines that barely lowered it.
  // Infinity: one tier.
  double first_tier_priority = std::numeric_limits<double>::infinity();
  // Direction balance (check 2): with a reference line cloud (the lines before any mitigation,
  // e.g. the conversion), no direction cell (privacy::DirectionCell, direction_bands) may have
  // lost more than ceil(F n_c) of its n_c reference lines, F = the share of the reference's
  // lines dropped in all once this call is done. Dropping where the attacks succeed removes
  // lines whose direction relative to the scene made them easy (see mitigation.h): unbalanced,
  // that failed the direction check on the demo's street. Lines of a cell at its cap are held
  // back like protected ones (and never dropped by break_coverage_when_short). Null: no cap.
  const slam::Map* direction_reference = nullptr;
  int direction_bands = 8;  // as MitigationOptions::direction_bands
};

struct CoverageDropReport {
  int num_lines = 0;
  int num_candidates = 0;          // lines with priority > 0
  int num_dropped = 0;
  int num_protected = 0;           // candidates skipped by the guard
  int num_dropped_protected = 0;   // dropped although protected (break_coverage_when_short)
  int num_held_for_directions = 0;  // candidates held back by the direction cap
};

// priority: per line id, larger goes first; lines missing or with priority <= 0 are never
// dropped. Ties broken by id. hidden_points: per line id, the point it passes through (world).
// Returns the copy without the dropped lines (and their ids removed from the server keyframes).
slam::Map DropWithKeyframeCoverage(const slam::Map& line_cloud,
                                   const std::map<slam::Id, double>& priority,
                                   const std::map<slam::Id, Eigen::Vector3d>& hidden_points,
                                   const CoverageDropOptions& options, CoverageDropReport* report);

// Coverage summary of a line cloud: server keyframes with at least min_lines_per_keyframe lines,
// and the image cells (over all keyframes) holding at least one line.
struct KeyframeCoverageStats {
  int keyframes = 0;
  int keyframes_with_min_lines = 0;
  int occupied_cells = 0;
  int min_lines = 0;  // fewest lines in a keyframe (0 without keyframes)
};
KeyframeCoverageStats MeasureKeyframeCoverage(
    const slam::Map& line_cloud, const std::map<slam::Id, Eigen::Vector3d>& hidden_points,
    const KeyframeCoverageOptions& options);

// The drop order "recovered first": per line id, 2 + risk if an attack named by a FAILING rule of
// the audit recovered the line's hidden point within the rule's tolerance, else risk (the
// largest over the attacks, <= 1), so recovered lines go first, the surest first (a tier of
// their own with CoverageDropOptions::first_tier_priority = kRecoveredPriority). Needs an audit run
// with a reference (report.reference_match); without one, returns the plain combined risk.
// excess (may be null): the largest, over the failing rules, number of recovered hidden points
// above the rule's limit: dropping fewer recovered lines than this cannot meet the limits.
inline constexpr double kRecoveredPriority = 2.0;
std::map<slam::Id, double> RecoveredFirstPriority(const AuditReport& report,
                                                  const std::vector<FailRule>& rules, int* excess);

// The audit's hidden point of every matched line (per id), for the guard.
std::map<slam::Id, Eigen::Vector3d> HiddenPointsOf(const AuditReport& report);

}  // namespace lcv::privacy
