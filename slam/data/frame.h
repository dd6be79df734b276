#pragma once
// A tracked image: keypoints, descriptors and unit bearings, a grid index over the keypoints for
// projection search, the pose and the landmark matched to each keypoint.
//
// Frames are runtime state of the tracking thread only (never shared across threads); a keyframe
// is a copy of a frame handed to local mapping (slam/data/slam_map.h).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "slam/bow/bow_vector.h"
#include "slam/camera/camera.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/rigid3.h"
#include "slam/util/ids.h"
#include "slam/util/shared_vector.h"

namespace lcv::slam {

// The image pyramid's scale per octave: level i is downscaled by scale_factor^i. Used to size
// search radii (a keypoint of octave o is uncertain by ~scale(o) px) and to predict the octave at
// which a landmark at distance d is seen.
class ScaleLevels {
 public:
  ScaleLevels() : ScaleLevels(1.2, 8) {}
  // Precondition: scale_factor > 1, num_levels >= 1 (checked).
  ScaleLevels(double scale_factor, int num_levels);

  int num_levels() const { return static_cast<int>(scale_.size()); }
  double scale_factor() const { return scale_factor_; }
  double log_scale_factor() const { return log_scale_factor_; }
  // scale_factor^octave, octave clamped to [0, num_levels).
  double Scale(int octave) const { return scale_[Clamp(octave)]; }
  // 1 / Scale(octave)^2: information weight of a keypoint of that octave.
  double InverseSigma2(int octave) const { return inverse_sigma2_[Clamp(octave)]; }

  // The octave at which a landmark whose scale-invariance range ends at max_distance is seen at
  // distance (ORB-SLAM's PredictScale), in [0, num_levels).
  int PredictOctave(double distance, double max_distance) const;

 private:
  int Clamp(int octave) const {
    return octave < 0 ? 0 : (octave >= num_levels() ? num_levels() - 1 : octave);
  }
  double scale_factor_ = 1.2;
  double log_scale_factor_ = 0.0;
  std::vector<double> scale_;
  std::vector<double> inverse_sigma2_;
};

// Keypoints bucketed into square pixel cells: radius queries in O(cells + hits) without sorting.
// Coordinates are raw image pixels (where keypoints were detected); keypoints outside the image
// are clamped into the border cells.
class KeypointGrid {
 public:
  // Rebuilds the index for these keypoints. cell_size_px > 0.
  void Build(const std::vector<Keypoint>& keypoints, int cols, int rows, int cell_size_px = 32);

  // Appends to *indices (cleared first) every keypoint i with |kp_i - center| <= radius_px (both
  // axes, a square window as ORB-SLAM) and min_octave <= octave <= max_octave (a negative
  // max_octave means no upper bound). Allocation-free once *indices has grown.
  void Query(const std::vector<Keypoint>& keypoints, float center_x, float center_y,
             float radius_px, int min_octave, int max_octave, std::vector<int>* indices) const;

  bool empty() const { return cells_.empty(); }
  // Cell of keypoint i (row-major): Query visits cells in increasing order and, within a cell,
  // keypoints in increasing index, which callers that search otherwise can reproduce.
  int CellOf(int i) const { return cells_[i]; }

 private:
  int cell_size_px_ = 32;
  int grid_cols_ = 0;
  int grid_rows_ = 0;
  // CSR layout: keypoint indices of cell c are cell_items_[cell_begin_[c] .. cell_begin_[c+1]).
  // Shared by copies (a keyframe's grid is copied with the map; slam/util/shared_vector.h).
  SharedVector<int> cell_begin_;
  SharedVector<int> cell_items_;
  SharedVector<int> cells_;  // cell of each keypoint
};

struct Frame {
  Id id = kInvalidId;       // sequence number, unique per run
  double timestamp = 0.0;   // seconds
  const Camera* camera = nullptr;  // not owned; outlives the frame
  ScaleLevels scale_levels;

  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;  // one per keypoint
  // Unit bearing of each keypoint in the camera frame; zero where the model cannot unproject.
  std::vector<Eigen::Vector3d> bearings;
  KeypointGrid grid;

  // Pose when has_pose (cam_from_world, map units).
  Rigid3d cam_from_world;
  bool has_pose = false;

  // Per keypoint: the landmark matched to it (kInvalidId when none) and whether pose
  // optimization flagged the match as an outlier.
  std::vector<Id> landmark_ids;
  std::vector<std::uint8_t> is_outlier;

  // The keyframe this frame was tracked against (for re-anchoring after map updates), and that
  // keyframe's pose and SlamKeyframe::scale in the snapshot the frame was tracked in
  // (reference_scale 0: not recorded). A keyframe candidate carries them to the map's writer,
  // which may have moved the map meanwhile (ReanchoredKeyframePose).
  Id reference_keyframe_id = kInvalidId;
  Rigid3d reference_cam_from_world;
  double reference_scale = 0.0;

  // Bag of words and direct index (slam/bow), computed only when needed (relocalization, or
  // when the frame becomes a keyframe); empty until then.
  BowVector bow;
  DirectIndex direct_index;

  int num_keypoints() const { return static_cast<int>(keypoints.size()); }
  // Number of keypoints with a landmark that is not flagged an outlier.
  int NumTrackedLandmarks() const;
  // Clears matches and outlier flags, keeps features.
  void ResetMatches();
};

// Fills bearings, grid, landmark_ids and is_outlier of a frame whose camera, keypoints and
// descriptors are set. cell_size_px: grid cell size.
void PrepareFrame(Frame* frame, int cell_size_px = 32);

}  // namespace lcv::slam
