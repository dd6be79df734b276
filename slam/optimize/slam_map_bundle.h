#pragma once
// Bundle problems assembled from the running SLAM map: the one place that decides how a landmark
// of a SlamMap enters a bundle adjustment (paper eqs. 6-9), shared by local BA (local mapping),
// the engine's global BA (slam/module/global_bundle_adjustment.h) and the rigid-stereo BA of
// relocalization in a line cloud.
//
// - A point X (SlamLandmark without line_id): a BundlePoint with one e_pP observation per
//   keyframe that sees it.
// - An X' (SlamLandmark::line_id set): a BundleLine holding the server line L (fixed: lines move
//   only in the line-cloud global BA of part 2) and the X' as its restored point, with one e_pL
//   observation per keyframe that sees it. BundleLine::id is the X' landmark's id.
//
// Thread safety: reads the map (the caller holds whatever keeps it from being written); writes
// only the problem it was given.

#include <map>
#include <vector>

#include "slam/data/slam_map.h"
#include "slam/optimize/bundle_adjustment.h"
#include "slam/util/ids.h"

namespace lcv::slam {

class SlamMapBundleBuilder {
 public:
  // Per observation of the problem: the landmark, keyframe and keypoint it links.
  struct Link {
    Id landmark_id = kInvalidId;
    Id keyframe_id = kInvalidId;
    int keypoint_index = -1;
  };

  // map and problem must outlive the builder. The problem may already hold keyframes added by
  // AddKeyframe of this builder only.
  SlamMapBundleBuilder(const SlamMap& map, BundleProblem* problem);

  // Index of client keyframe `id` in the problem, adding it with `fixed` the first time.
  // Precondition: the keyframe exists (checked).
  int AddKeyframe(Id id, bool fixed);

  // Adds a landmark (point or X') and every observation of it. Observing keyframes not added yet
  // are added as fixed (local BA's border keyframes). Observations the camera cannot image at
  // the current state start as outliers (Ceres would abort on them). Returns false, adding
  // nothing, when the landmark does not exist, has no observations, or is an X' whose line is
  // missing.
  bool AddLandmark(Id landmark_id);

  const std::vector<Link>& links() const { return links_; }

 private:
  const SlamMap& map_;
  BundleProblem* problem_;
  std::map<Id, int> keyframe_index_;
  std::vector<Link> links_;
};

// Writes the solved positions of the problem's points and X' (restored points of its lines)
// into the map's landmarks of the same ids; landmarks erased since are skipped. Returns the ids
// written.
std::vector<Id> WriteBackLandmarkPositions(const BundleProblem& problem, SlamMap* map);

}  // namespace lcv::slam
