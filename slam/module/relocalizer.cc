#include "slam/module/relocalizer.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <unordered_map>

#include "slam/match/bow_matcher.h"
#include "slam/match/projection_matcher.h"
#include "slam/optimize/motion_only_ba.h"
#include "slam/solve/absolute_pose.h"
#include "slam/util/error.h"

namespace lcv::slam {

std::optional<std::string> RelocalizerOptions::Problem() const {
  if (max_candidates < 1) return "max_candidates must be >= 1";
  if (!(min_common_words_ratio >= 0.0 && min_common_words_ratio <= 1.0)) {
    return "min_common_words_ratio must be in [0, 1]";
  }
  if (group_neighbours < 0) return "group_neighbours must be >= 0";
  if (!(group_score_ratio >= 0.0 && group_score_ratio <= 1.0)) {
    return "group_score_ratio must be in [0, 1]";
  }
  if (min_bow_matches < 3) return "min_bow_matches must be >= 3";
  if (!(bow_ratio > 0.f && bow_ratio <= 1.f)) return "bow_ratio must be in (0, 1]";
  if (raw_score_candidates < 0) return "raw_score_candidates must be >= 0";
  if (!(max_angular_error_rad >= 0.0)) return "max_angular_error_rad must be >= 0";
  if (max_angular_error_rad == 0.0 && !(max_ransac_error_px > 0.0)) {
    return "max_ransac_error_px must be > 0 when max_angular_error_rad is 0";
  }
  if (max_ransac_trials < 1) return "max_ransac_trials must be >= 1";
  if (min_ransac_inliers < 3) return "min_ransac_inliers must be >= 3";
  if (min_optimized_inliers < 3) return "min_optimized_inliers must be >= 3";
  if (min_inliers < 3) return "min_inliers must be >= 3";
  if (local_keyframes < 0) return "local_keyframes must be >= 0";
  if (!(wide_search_radius_px > 0.f) || !(narrow_search_radius_px > 0.f)) {
    return "search radii must be > 0";
  }
  return std::nullopt;
}

std::vector<Id> RelocalizationCandidates(const BowDatabase& database, const SlamMap& map,
                                         const BowVector& bow, const RelocalizerOptions& options) {
  std::vector<BowQueryResult> results = database.Query(bow, 0);
  // Keyframes of the active segment only: the others are in frames of their own, reached by
  // loop closing's merge (SlamMap segments).
  results.erase(std::remove_if(results.begin(), results.end(),
                               [&](const BowQueryResult& r) {
                                 const SlamKeyframe* kf = map.FindKeyframe(r.keyframe_id);
                                 return kf == nullptr || kf->segment != map.active_segment();
                               }),
                results.end());
  int max_common = 0;
  for (const BowQueryResult& r : results) max_common = std::max(max_common, r.num_shared_words);
  const double min_common = options.min_common_words_ratio * max_common;
  std::unordered_map<Id, double> score_of;  // keyframes sharing enough words
  for (const BowQueryResult& r : results) {
    if (r.num_shared_words >= min_common) score_of[r.keyframe_id] = r.score;
  }

  // Group scores: a keyframe with its best covisible neighbours that were kept too.
  struct Group {
    double accumulated = 0.0;
    Id best_keyframe = kInvalidId;
  };
  std::vector<Group> groups;
  double best_accumulated = 0.0;
  for (const BowQueryResult& r : results) {
    if (!score_of.count(r.keyframe_id)) continue;
    Group group{r.score, r.keyframe_id};
    double best_score = r.score;
    for (const Id neighbour : map.CovisibleKeyframes(r.keyframe_id, options.group_neighbours)) {
      const auto it = score_of.find(neighbour);
      if (it == score_of.end()) continue;
      group.accumulated += it->second;
      if (it->second > best_score || (it->second == best_score && neighbour < group.best_keyframe)) {
        best_score = it->second;
        group.best_keyframe = neighbour;
      }
    }
    best_accumulated = std::max(best_accumulated, group.accumulated);
    groups.push_back(group);
  }
  std::stable_sort(groups.begin(), groups.end(), [](const Group& a, const Group& b) {
    return a.accumulated != b.accumulated ? a.accumulated > b.accumulated
                                          : a.best_keyframe < b.best_keyframe;
  });
  std::vector<Id> candidates;
  std::set<Id> seen;
  for (const Group& group : groups) {
    if (group.accumulated <= options.group_score_ratio * best_accumulated) break;
    if (!seen.insert(group.best_keyframe).second) continue;
    candidates.push_back(group.best_keyframe);
    if (static_cast<int>(candidates.size()) >= options.max_candidates) break;
  }
  // Then the best keyframes by their own score (results are sorted by it): a keyframe at the
  // frontier of the map has few covisible neighbours to share a group score with, and is exactly
  // the one a frame that just left the map sees best.
  int added = 0;
  for (const BowQueryResult& r : results) {
    if (added >= options.raw_score_candidates) break;
    if (!score_of.count(r.keyframe_id)) continue;
    ++added;
    if (seen.insert(r.keyframe_id).second) candidates.push_back(r.keyframe_id);
  }
  return candidates;
}

namespace {

// The angle between the bearings of the image centre and the pixel to its right (radians): the
// angular size of a pixel, to turn pixel thresholds into the solvers' bearing errors.
double PixelAngle(const Camera& camera) {
  const Eigen::Vector2d centre(0.5 * (camera.cols() - 1), 0.5 * (camera.rows() - 1));
  const std::optional<Eigen::Vector3d> a = camera.Unproject(centre);
  const std::optional<Eigen::Vector3d> b = camera.Unproject(centre + Eigen::Vector2d(1.0, 0.0));
  if (!a || !b) return 2.0 * M_PI / std::max(1, camera.cols());
  return std::atan2(a->cross(*b).norm(), a->dot(*b));
}

// Relocalization against one candidate at a time (steps 2-6); buffers reused across candidates.
class Attempt {
 public:
  Attempt(const SlamMap& map, const RelocalizerOptions& options, Frame* frame)
      : map_(map), options_(options), frame_(frame) {}

  // Returns the number of inliers at the final pose (the frame then holds the pose and only the
  // inlier matches), or 0 when the candidate fails before pose optimization.
  int Run(const SlamKeyframe& candidate, std::uint64_t seed) {
    frame_->ResetMatches();
    if (!InitialPose(candidate, seed)) return 0;
    int inliers = OptimizePose();
    if (inliers < options_.min_optimized_inliers || inliers >= options_.min_inliers) {
      return inliers;
    }
    CollectLocalLandmarks(candidate);
    int added = SearchByProjection(options_.wide_search_radius_px,
                                   options_.wide_search_max_distance);
    if (inliers + added < options_.min_inliers) return inliers;
    inliers = OptimizePose();
    if (inliers > options_.narrow_search_min_inliers && inliers < options_.min_inliers) {
      added = SearchByProjection(options_.narrow_search_radius_px,
                                 options_.narrow_search_max_distance);
      if (inliers + added >= options_.min_inliers) inliers = OptimizePose();
    }
    return inliers;
  }

 private:
  // Steps 2-3: BoW matches, P3P RANSAC; the RANSAC inliers become the frame's matches.
  bool InitialPose(const SlamKeyframe& candidate, std::uint64_t seed) {
    BowMatchOptions bow_options;
    bow_options.max_distance = options_.bow_max_distance;
    bow_options.ratio = options_.bow_ratio;
    bow_options.check_orientation = options_.check_orientation;
    MatchKeyframeLandmarksByBow(candidate, *frame_, bow_options, &bow_matches_);
    bearings_.clear();
    points_.clear();
    matches_.clear();
    for (const BowLandmarkMatch& m : bow_matches_) {
      const SlamLandmark* landmark = map_.FindLandmark(m.landmark_id);
      if (landmark == nullptr || frame_->bearings[m.frame_keypoint].squaredNorm() < 0.5) continue;
      bearings_.push_back(frame_->bearings[m.frame_keypoint]);
      points_.push_back(landmark->position_in_world);
      matches_.push_back(m);
    }
    if (static_cast<int>(matches_.size()) < options_.min_bow_matches) return false;

    AbsolutePoseOptions pose_options;
    pose_options.max_angular_error_rad =
        options_.max_angular_error_rad > 0.0
            ? options_.max_angular_error_rad
            : options_.max_ransac_error_px * PixelAngle(*frame_->camera);
    pose_options.ransac.max_error = 0.0;  // 0: use max_angular_error_rad
    pose_options.ransac.max_num_trials = options_.max_ransac_trials;
    pose_options.ransac.random_seed = seed;
    pose_options.min_num_inliers = options_.min_ransac_inliers;
    const AbsolutePoseResult pose = EstimateAbsolutePose(bearings_, points_, pose_options);
    if (!pose.success) return false;
    frame_->cam_from_world = pose.cam_from_world;
    // RANSAC outliers stay as flagged matches: pose optimization starts without them and
    // re-admits those that fit the refined pose (an angular threshold is tight in pixels on a
    // wide camera, where good matches near the noise level fall just outside it).
    for (std::size_t k = 0; k < matches_.size(); ++k) {
      const int i = matches_[k].frame_keypoint;
      frame_->landmark_ids[i] = matches_[k].landmark_id;
      frame_->is_outlier[i] = pose.inlier_mask[k] ? 0 : 1;
    }
    return true;
  }

  // Step 4: motion-only BA on the frame's matches (those flagged is_outlier start excluded);
  // outliers are unlinked, inliers unflagged. Returns the inliers.
  int OptimizePose() {
    terms_.clear();
    term_keypoints_.clear();
    for (int i = 0; i < frame_->num_keypoints(); ++i) {
      const Id id = frame_->landmark_ids[i];
      if (id == kInvalidId) continue;
      MotionOnlyPointTerm term;
      term.p_in_world = map_.FindLandmark(id)->position_in_world;
      term.observed_px = Eigen::Vector2d(frame_->keypoints[i].x, frame_->keypoints[i].y);
      term.information = frame_->scale_levels.InverseSigma2(frame_->keypoints[i].octave);
      term.inlier = !frame_->is_outlier[i];
      terms_.push_back(term);
      term_keypoints_.push_back(i);
    }
    Rigid3d pose = frame_->cam_from_world;
    const MotionOnlyBAReport report =
        terms_.size() >= 3 ? ba_.Solve(*frame_->camera, &pose, &terms_, &line_terms_)
                           : MotionOnlyBAReport();
    if (!report.success) {
      frame_->ResetMatches();
      return 0;
    }
    pose.rotation.normalize();
    frame_->cam_from_world = pose;
    int inliers = 0;
    for (std::size_t k = 0; k < terms_.size(); ++k) {
      const int i = term_keypoints_[k];
      frame_->is_outlier[i] = 0;
      if (terms_[k].inlier) {
        ++inliers;
      } else {
        frame_->landmark_ids[i] = kInvalidId;
      }
    }
    return inliers;
  }

  // The landmarks of the candidate and its best covisible keyframes, each with the keypoint
  // angle of one observation (for the orientation check), in id order.
  void CollectLocalLandmarks(const SlamKeyframe& candidate) {
    local_.clear();
    std::vector<const SlamKeyframe*> keyframes = {&candidate};
    for (const Id id : map_.CovisibleKeyframes(candidate.id, options_.local_keyframes)) {
      if (const SlamKeyframe* kf = map_.FindKeyframe(id)) keyframes.push_back(kf);
    }
    for (const SlamKeyframe* kf : keyframes) {
      for (std::size_t i = 0; i < kf->landmark_ids.size(); ++i) {
        const Id id = kf->landmark_ids[i];
        if (id != kInvalidId) local_.emplace(id, kf->keypoints[i].angle_deg);  // first one wins
      }
    }
  }

  // Step 5: local landmarks not matched yet, in the frame's view at its current pose.
  int SearchByProjection(float radius_px, int max_distance) {
    std::vector<Id> matched;
    for (const Id id : frame_->landmark_ids) {
      if (id != kInvalidId) matched.push_back(id);
    }
    std::sort(matched.begin(), matched.end());
    const Camera& camera = *frame_->camera;
    const ScaleLevels& levels = frame_->scale_levels;
    const Rigid3d& pose = frame_->cam_from_world;
    const Eigen::Matrix3d R = pose.RotationMatrix();
    const double cos_max_camera = std::cos(std::min(camera.MaxViewAngle(), M_PI));
    candidates_.clear();
    for (const auto& [id, angle_deg] : local_) {
      if (std::binary_search(matched.begin(), matched.end(), id)) continue;
      const SlamLandmark* landmark = map_.FindLandmark(id);
      if (landmark == nullptr) continue;
      const Eigen::Vector3d p_in_cam = R * landmark->position_in_world + pose.translation;
      const double distance = p_in_cam.norm();
      if (!(distance > 0.0) || p_in_cam.z() / distance < cos_max_camera - 1e-12) continue;
      if (distance < 0.8 * landmark->min_distance || distance > 1.2 * landmark->max_distance) {
        continue;
      }
      const int octave = levels.PredictOctave(distance, landmark->max_distance);
      ProjectionCandidate c;
      c.landmark_id = id;
      c.position_in_world = landmark->position_in_world;
      c.descriptor = landmark->descriptor;
      c.min_octave = std::max(0, octave - 1);
      c.max_octave = octave + 1;
      c.radius_px = static_cast<float>(radius_px * levels.Scale(octave));
      c.reference_angle_deg = angle_deg;
      candidates_.push_back(c);
    }
    ProjectionMatchOptions match_options;
    match_options.max_hamming_distance = max_distance;
    match_options.ratio = 1.f;  // ORB-SLAM's relocalization search has no ratio test
    match_options.check_orientation = options_.check_orientation;
    return MatchByProjection(candidates_, pose, match_options, frame_, &scratch_);
  }

  const SlamMap& map_;
  const RelocalizerOptions& options_;
  Frame* frame_;
  MotionOnlyBA ba_;
  std::vector<BowLandmarkMatch> bow_matches_;
  std::vector<BowLandmarkMatch> matches_;  // those with a landmark and a bearing
  std::vector<Eigen::Vector3d> bearings_, points_;
  std::vector<MotionOnlyPointTerm> terms_;
  std::vector<MotionOnlyLineTerm> line_terms_;
  std::vector<int> term_keypoints_;
  std::map<Id, float> local_;  // local landmark -> reference keypoint angle
  std::vector<ProjectionCandidate> candidates_;
  ProjectionMatchScratch scratch_;
};

}  // namespace

std::optional<RelocalizationResult> Relocalize(const Vocabulary& vocabulary,
                                               const BowDatabase& database, const SlamMap& map,
                                               const RelocalizerOptions& options,
                                               std::uint64_t seed, Frame* frame) {
  LCV_CHECK(frame != nullptr && frame->camera != nullptr);
  const std::optional<std::string> problem = options.Problem();
  LCV_CHECK(!problem) << *problem;
  LCV_CHECK(frame->landmark_ids.size() == frame->keypoints.size() &&
            frame->bearings.size() == frame->keypoints.size())
      << "frame not prepared (PrepareFrame)";
  if (frame->bow.empty() || frame->direct_index.empty()) {
    vocabulary.Transform(frame->descriptors, &frame->bow, &frame->direct_index, kDirectIndexLevel);
  }
  const Rigid3d saved_pose = frame->cam_from_world;
  const bool saved_has_pose = frame->has_pose;
  const Id saved_reference = frame->reference_keyframe_id;

  const std::vector<Id> candidates = RelocalizationCandidates(database, map, frame->bow, options);
  Attempt attempt(map, options, frame);
  RelocalizationResult result;
  for (const Id candidate_id : candidates) {
    ++result.num_candidates_tried;
    // A seed per candidate: the outcome for one candidate does not depend on the others.
    const std::uint64_t candidate_seed = seed * 1000003u + candidate_id;
    const int inliers = attempt.Run(*map.FindKeyframe(candidate_id), candidate_seed);
    if (inliers >= options.min_inliers) {
      frame->has_pose = true;
      frame->reference_keyframe_id = candidate_id;
      result.keyframe_id = candidate_id;
      result.num_inliers = inliers;
      return result;
    }
  }
  frame->ResetMatches();
  frame->cam_from_world = saved_pose;
  frame->has_pose = saved_has_pose;
  frame->reference_keyframe_id = saved_reference;
  return std::nullopt;
}

}  // namespace lcv::slam
