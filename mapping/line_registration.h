#pragma once
// Registration of one line cloud to another (issue 13, "independent frames"): the Sim(3)
// base_from_upload between two line clouds of the same place built in independent sessions.
//
// 1. Candidates: line-line correspondences from the binary descriptors. OpenCV's FLANN LSH index
//    (cv::flann::LshIndexParams, Hamming distance) over the base descriptors, the k nearest for
//    every upload line, kept when the Hamming distance is <= max_hamming. Lines without a
//    descriptor take no part (a line cloud without descriptors cannot be registered here).
// 2. Model: two lines through the same physical point intersect. For the upload line
//    {p_u, d_u} (upload frame) mapped by S = (s, R, t) and the base line {p_b, d_b}, with Pluecker
//    moments m = p x d, the lines meet iff their reciprocal product vanishes:
//      s d_b . (R m_u) + t . (R d_u x d_b) + (R d_u) . m_b = 0,                      (1)
//    one equation per correspondence, linear in (s, t) for a given R (the generalized relative
//    pose with scale between two "generalized cameras" whose rays are the lines, as p6L is for a
//    central camera against lines). Minimal solver (7 correspondences): Levenberg-Marquardt on
//    the 7 parameters (R on its left perturbation) from the 24 rotations of the cube group, (s, t)
//    from (1) in least squares for each start; the distinct solutions with s > 0 and residual
//    ~0 are returned for RANSAC to score (like SolveP4L, not guaranteed to find every root).
//    Data are centred and scaled to unit RMS on both sides first (conditioning of (1)).
// 3. RANSAC (slam/solve/ransac.h) with the distance between the transformed upload line and the
//    base line (base units) as residual, then iteratively re-weighted refinement of the 7
//    parameters on that distance over the inliers (Huber).
// 4. Check (a wrong registration is rejected with a reason): at least min_inliers inliers, at
//    least min_inlier_ratio of the candidates, a plausible scale, and more inliers than
//    chance_factor x the count expected by chance: the same model scored on the candidates with
//    their base lines shuffled (lines pass within the threshold of unrelated lines at some rate;
//    a 7-dof fit of an unrelated place reaches that rate plus its sample, a true one far more).
//
// Thread safety: functions are reentrant; LineDescriptorIndex is const after construction and
// may be queried from several threads.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "slam/feature/keypoint.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/sim3.h"

namespace lcv::mapping {

// Nearest descriptors by Hamming distance (FLANN LSH). Indices refer to the vector given.
class LineDescriptorIndex {
 public:
  // multi_probe_level: LSH buckets probed at Hamming distance up to it from the query's key
  // (2: better recall; 1: several times faster on large indexes).
  explicit LineDescriptorIndex(const std::vector<slam::OrbDescriptor>& descriptors,
                               int multi_probe_level = 2);
  ~LineDescriptorIndex();
  LineDescriptorIndex(const LineDescriptorIndex&) = delete;
  LineDescriptorIndex& operator=(const LineDescriptorIndex&) = delete;

  int size() const { return static_cast<int>(descriptors_.size()); }
  // Up to k neighbours of query (index, Hamming distance), nearest first, distance <= max_hamming.
  // Approximate (LSH): a neighbour may be missed.
  void Query(const slam::OrbDescriptor& query, int k, int max_hamming,
             std::vector<std::pair<int, int>>* neighbours) const;
  // The same for queries [first, first + count) of the indexed descriptors themselves, in one
  // FLANN call (much less overhead per query); neighbours->at(i) for query first + i.
  void QueryIndexed(int first, int count, int k, int max_hamming,
                    std::vector<std::vector<std::pair<int, int>>>* neighbours) const;

 private:
  struct Impl;
  std::vector<slam::OrbDescriptor> descriptors_;
  std::unique_ptr<Impl> impl_;
};

struct LineRegistrationOptions {
  int max_hamming = 50;           // candidate descriptor distance (of 256 bits)
  int candidates_per_line = 2;    // k nearest base descriptors per upload line
  double inlier_distance = 0.0;   // base units; <= 0: inlier_distance_relative x scene_scale
  double inlier_distance_relative = 0.003;
  int max_trials = 5000;          // RANSAC trials (minimal sample 7)
  int min_inliers = 30;
  double min_inlier_ratio = 0.05;  // of the candidates
  double chance_factor = 4.0;
  // Base units per upload unit: as LineCloudRegistrationOptions' range (an upload from a
  // monocular client is in that client's unit, about its first scene depth).
  double min_scale = 1e-6, max_scale = 1e6;
  std::uint64_t seed = 0;
  std::string Problem() const;  // empty when usable
};

struct LineCorrespondence {
  int upload = -1;  // index into the upload lines
  int base = -1;    // index into the base lines
  int hamming = 0;
};

struct LineRegistrationResult {
  bool success = false;
  std::string reason;  // why it was rejected, or a summary when accepted
  slam::Sim3d base_from_upload;
  int num_candidates = 0;
  int num_inliers = 0;
  int num_trials = 0;
  double chance_inliers = 0.0;  // expected inliers of a wrong model (see the header)
  double inlier_distance = 0.0; // threshold used, base units
  double rms_distance = 0.0;    // of the inliers after refinement, base units
  std::vector<LineCorrespondence> inliers;  // one per upload line at most (the closest)
};

// Distance (base units) between the upload line mapped by base_from_upload and the base line;
// for parallel lines, the distance between them.
double LineLineDistance(const slam::Sim3d& base_from_upload, const slam::Line3d& upload_line,
                        const slam::Line3d& base_line);

// Minimal / non-minimal solver of (1) from count >= 7 correspondences (lines given pairwise).
// Returns the number of solutions written to *solutions (cleared first).
int SolveSim3LineLine(const slam::Line3d* upload_lines, const slam::Line3d* base_lines, int count,
                      std::vector<slam::Sim3d>* solutions);

// Refines *base_from_upload on the distances of the pairs (IRLS, Huber at huber_distance).
// False (unchanged) with fewer than 7 pairs or a singular system.
bool RefineSim3LineLine(const slam::Line3d* upload_lines, const slam::Line3d* base_lines,
                        int count, double huber_distance, slam::Sim3d* base_from_upload);

// The whole registration. scene_scale (base units, > 0) sets the default inlier distance.
// base_index holds base_descriptors; a base line without descriptor is absent from it, so
// base_index positions map to base lines through base_index_lines.
LineRegistrationResult RegisterLineCloud(const std::vector<slam::Line3d>& base_lines,
                                         const LineDescriptorIndex& base_index,
                                         const std::vector<int>& base_index_lines,
                                         const std::vector<slam::Line3d>& upload_lines,
                                         const std::vector<std::optional<slam::OrbDescriptor>>&
                                             upload_descriptors,
                                         double scene_scale,
                                         const LineRegistrationOptions& options);

}  // namespace lcv::mapping
