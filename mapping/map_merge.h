#pragma once
// Map curation (issue 13): merge line clouds uploaded by clients into a base line cloud.
//
// Each upload is first made a line cloud (an upload that still holds client keyframes or points
// is converted by ConvertToLineCloud with a seed of its own), then joins the merged map in one of
// two ways:
// - same frame: made by a client that relocalized in the base map, it shares the base frame and
//   refers to base line ids (its copies of base lines carry the base descriptor). Detected when
//   at least 6 and at least half of the upload's lines whose id is a base line id have the same
//   descriptor (Hamming <= 10) or, without descriptors, the same direction (< 1 degree).
//   Such lines are the base lines: they gain the upload's server keyframes as visibility
//   ("lines_merged"). The upload's other lines are new lines with fresh ids ("lines_added").
// - independent frame: registered first (mapping/line_registration.h), rejected with the reason
//   when the registration fails. Registration inliers are the base lines seen again (merged);
//   the rest is mapped by base_from_upload (poses by TransformPose, lines and their Omega_L) and
//   added with fresh ids.
// Server keyframes of an accepted upload always join with fresh ids. Cameras are copied with
// fresh ids. Line anchors are re-drawn by the line-cloud rule (closest point to the origin), and
// Finish() sets every line's Omega_L by the publishing rule (SetProxyInformation) on the merged
// map, whatever the uploads carried; the optimization weighs with the uploads' own Omega_L.
//
// Virtual observations (paper eq. 4-5) are recorded at merge time, for every (server keyframe,
// line) pair of each upload, from the UPLOAD's own pose and line (mapped into the base frame): a
// relative measurement of the upload, valid even where its keyframes drift. The base's own
// pairs are recorded from the base. The global optimization (merge_optimization.h) uses them.
//
// Privacy rule: two lines through one physical point are never both published (their
// intersection reveals it). Finish() searches pairs with a descriptor match (Hamming <=
// duplicate_max_hamming, candidates by multi-index hashing: 16 chunks of 16 bits, see
// DescriptorPairs in map_merge.cc; FLANN's LSH queries took minutes on a 1M-line map), near-intersection (distance <= duplicate distance, see
// MapMergeOptions) and visibility consistency (a server keyframe sees both, or each line is in
// front of a server keyframe that sees the other), and keeps one line per group: a base line
// when the group has one, else the smallest id. The dropped lines' visibility and virtual
// observations move to the kept line. Lines without descriptors are not searched here (the
// audit's duplicate attack still checks exact intersections).
//
// Thread safety: a MapMerger is used by one thread. Failure: bad options -> std::logic_error;
// an upload that cannot be merged is rejected in its UploadMergeResult, never an exception.

#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <optional>
#include <string>
#include <vector>

#include "mapping/line_registration.h"
#include "mapping/merge_optimization.h"
#include "slam/data/map.h"

namespace lcv::mapping {

enum class UploadFrame { kAuto, kSame, kIndependent };

struct MapMergeOptions {
  UploadFrame frame = UploadFrame::kAuto;
  LineRegistrationOptions registration;
  int duplicate_max_hamming = 50;
  // Two lines are "near-intersecting" when their distance is <= duplicate_sigma_factor x the
  // combined perpendicular sigma of the two lines (from pinv(Omega_L)), clamped to
  // [duplicate_min_relative, duplicate_max_relative] x scene scale (base camera extent).
  double duplicate_sigma_factor = 3.0;
  double duplicate_min_relative = 0.003;
  double duplicate_max_relative = 0.01;
  std::uint64_t seed = 0;  // conversion of uploads that still hold points (+ upload index)
  bool optimize = false;
  MergeOptimizationOptions optimization;
  std::string Problem() const;  // empty when usable
};

struct UploadMergeResult {
  std::string name;
  bool accepted = false;
  std::string reason;
  std::string frame;  // "same" or "independent" (empty when rejected before deciding)
  std::optional<slam::Sim3d> base_from_upload;  // independent frame only
  int server_keyframes_added = 0;
  int lines_added = 0;    // new lines (fresh ids)
  int lines_merged = 0;   // upload lines that are base lines seen again
  int lines_dropped = 0;  // added lines removed by the privacy rule in Finish()
  int registration_candidates = 0;
  int registration_inliers = 0;
};

struct MapMergeReport {
  std::vector<UploadMergeResult> uploads;
  int duplicate_groups = 0;  // privacy rule: groups of lines through one point
  int lines_dropped = 0;
  std::optional<MergeOptimizationReport> optimization;
  double seconds = 0.0;
};

class MapMerger {
 public:
  // base: a line cloud (a map with points or client keyframes is converted with options.seed).
  MapMerger(const slam::Map& base, const MapMergeOptions& options);
  ~MapMerger();

  UploadMergeResult AddUpload(const slam::Map& upload, const std::string& name);
  // Records a rejected upload (e.g. unreadable) so that the report keeps the order given.
  void AddRejected(const std::string& name, const std::string& reason);

  // Privacy rule, then the optimization when options.optimize, then the privacy rule again
  // (lines moved). Returns the merged line cloud; the merger is spent afterwards.
  slam::Map Finish(MapMergeReport* report);

  const slam::Map& map() const { return map_; }
  double scene_scale() const { return scene_scale_; }

 private:
  struct Registration;
  UploadMergeResult AddSameFrame(const slam::Map& upload, UploadMergeResult result);
  void AddLines(const slam::Map& upload, const std::optional<slam::Sim3d>& base_from_upload,
                const std::map<slam::Id, slam::Id>& merged_ids, int upload_number,
                UploadMergeResult* result);
  int ApplyPrivacyRule(MapMergeReport* report);

  MapMergeOptions options_;
  slam::Map map_;
  std::set<slam::Id> base_lines_, base_server_keyframes_;
  std::map<slam::Id, int> line_origin_;  // added line -> index into results_
  std::vector<VirtualObservationRecord> virtual_observations_;
  std::vector<ObservedLineCopy> copies_;
  std::vector<UploadMergeResult> results_;
  double scene_scale_ = 1.0;
  slam::Id next_id_ = 0;
  std::unique_ptr<Registration> registration_;  // base descriptor index, built on first use
};

// Scene scale of a line cloud for relative tolerances: the diagonal of its server keyframe
// centres' bounding box (1 when it has fewer than two).
double CameraExtent(const slam::Map& map);

}  // namespace lcv::mapping
