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

// The server side of a bundle in a registered line cloud (paper eq. 9), shared by the engine's
// global BA and, with LineCloud.local_ba_frees_line_cloud, local BA. Call after the client side
// (keyframes and landmarks) is in the problem. Every line of the problem (the lines of its X')
// becomes free (minimal 4-dof updates). The server keyframes that see those lines are ranked by
// how many of them they see; the first max_free_server_keyframes (all when negative) join the
// problem with every other line they see that two or more server keyframes see (a line seen by
// one holds nothing: it can turn and slide in that keyframe's view plane). The other server
// keyframes that see a line of the problem join fixed: the border that holds the server map's
// gauge and scale. free_server_keyframes false fixes every server keyframe (only lines move);
// true leaves the joined ones free, fixing the two that see the fewest X' lines when the border
// has fewer than two. Each (server keyframe, line) pair of the problem gets a virtual
// observation e_vL made from the current state, or, with virtual_from_published, from the line
// and the server keyframe as loaded (the paper's L0: across bundles a moved line is pulled back
// toward the view planes it was published in; measured in docs/slam.md "Local BA moves the
// client's lines"). Returns the SlamLine id of each
// problem->lines entry (BundleLine::id stays the X' landmark, kInvalidId for lines without one).
struct LineCloudBundleOptions {
  bool free_server_keyframes = false;
  int max_free_server_keyframes = -1;
  // The virtual observations v from each line and server keyframe as loaded
  // (SlamLine::published_line, SlamServerKeyframe::published_cam_from_world; the paper's L0)
  // instead of their current state: a line moved by earlier bundles is pulled back toward the
  // view planes it was published in.
  bool virtual_from_published = false;
  // > 0: each virtual observation's sigma is this many pixels of its server keyframe's camera
  // (PixelAngle), instead of BundleOptions::virtual_sigma_rad for every camera.
  double virtual_sigma_px = 0.0;
};
std::vector<Id> AddLineCloudToBundle(const SlamMap& map, const LineCloudBundleOptions& options,
                                     BundleProblem* problem);

// Writes the lines and free server keyframes of a solved line-cloud bundle back: lines anchored
// at the foot of their old anchor (so a line's visible interval keeps its meaning) with Omega_L
// turned by the smallest rotation from the old direction to the new one (TurnLineInformation)
// and its square root recomputed.
// line_ids: AddLineCloudToBundle's result. Erased lines and server keyframes are skipped.
void WriteBackLineCloud(const BundleProblem& problem, const std::vector<Id>& line_ids,
                        SlamMap* map);

// Writes the solved positions of the problem's points and X' (restored points of its lines)
// into the map's landmarks of the same ids; landmarks erased since are skipped. Returns the ids
// written.
std::vector<Id> WriteBackLandmarkPositions(const BundleProblem& problem, SlamMap* map);

}  // namespace lcv::slam
