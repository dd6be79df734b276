// Tracker's motion-only BA on the frame's matches (slam/tracking.h): points X with e_pP, X' and
// keypoints matched to lines with e_pL. Split from tracking.cc to keep files small.
#include "slam/tracking.h"

namespace lcv::slam {

int Tracker::OptimizePose(const LocalMapSnapshot& snapshot, Frame* frame) {
  // e_pP for points X and for the X' that enough keyframes observe
  // (LineCloud.track_restored_as_points_min_observations); e_pL (eq. 6, X' free) for the other
  // X' and for keypoints matched to a line that has no X' yet (X' starts midway between the
  // keypoint's ray and the line).
  const int fixed_restored_min = options_.line_cloud.track_restored_as_points_min_observations;
  point_terms_.clear();
  line_terms_.clear();
  term_keypoints_.clear();
  line_term_keypoints_.clear();
  line_term_is_map_point_.clear();
  point_term_is_restored_.clear();
  for (int i = 0; i < frame->num_keypoints(); ++i) {
    const Id id = frame->landmark_ids[i];
    if (id == kInvalidId) continue;
    const Eigen::Vector2d observed(frame->keypoints[i].x, frame->keypoints[i].y);
    const double information = frame->scale_levels.InverseSigma2(frame->keypoints[i].octave);
    const SnapshotLandmark* landmark = snapshot.FindLandmark(id);
    const SnapshotLine* line =
        landmark != nullptr ? snapshot.FindLine(landmark->line_id) : snapshot.FindLine(id);
    const bool restored_as_point = line != nullptr && landmark != nullptr &&
                                   fixed_restored_min > 0 &&
                                   landmark->num_observations >= fixed_restored_min;
    if (line != nullptr && !restored_as_point &&
        (landmark != nullptr || frame->bearings[i].squaredNorm() > 0.5)) {
      MotionOnlyLineTerm term;
      term.line = line->line;
      term.sqrt_information = line->sqrt_information;
      term.observed_px = observed;
      term.information = information;
      term.restored_point =
          landmark != nullptr
              ? landmark->position_in_world
              : InitialRestoredPoint(frame->cam_from_world, frame->bearings[i], line->line);
      line_terms_.push_back(term);
      line_term_keypoints_.push_back(i);
      line_term_is_map_point_.push_back(landmark != nullptr);
      continue;
    }
    if (landmark == nullptr) {
      frame->landmark_ids[i] = kInvalidId;
      continue;
    }
    MotionOnlyPointTerm term;
    term.p_in_world = landmark->position_in_world;
    term.observed_px = observed;
    term.information = information;
    point_terms_.push_back(term);
    term_keypoints_.push_back(i);
    point_term_is_restored_.push_back(restored_as_point);
  }
  const int num_terms = static_cast<int>(point_terms_.size() + line_terms_.size());
  if (num_terms < 3) return num_terms;
  Rigid3d pose = frame->cam_from_world;
  const MotionOnlyBAReport report =
      motion_only_ba_.Solve(*frame->camera, &pose, &point_terms_, &line_terms_);
  if (!report.success) return 0;
  frame->cam_from_world = pose;
  int inliers = 0;
  auto classify = [&](int i, bool inlier) {
    frame->is_outlier[i] = 0;
    if (inlier) {
      ++inliers;
    } else {
      frame->landmark_ids[i] = kInvalidId;
    }
  };
  last_num_line_inliers_ = 0;
  last_num_new_line_inliers_ = 0;
  for (size_t k = 0; k < point_terms_.size(); ++k) {
    classify(term_keypoints_[k], point_terms_[k].inlier);
    last_num_line_inliers_ += point_terms_[k].inlier && point_term_is_restored_[k];
  }
  for (size_t k = 0; k < line_terms_.size(); ++k) {
    classify(line_term_keypoints_[k], line_terms_[k].inlier);
    last_num_line_inliers_ += line_terms_[k].inlier;
    last_num_new_line_inliers_ += line_terms_[k].inlier && !line_term_is_map_point_[k];
  }
  return inliers;
}

}  // namespace lcv::slam
