// The line-cloud side of LocalMapper (slam/local_mapping.h): loading a server line cloud,
// preparing it for tracking (where each line's hidden point can lie, BoW of the server
// keyframes) and registering the client's map into it (paper Sec. 3.2).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "slam/bow/vocabulary.h"
#include "slam/local_mapping.h"
#include "slam/match/line_projection_matcher.h"
#include "slam/module/line_cloud_loop.h"
#include "slam/module/line_cloud_relocalizer.h"

namespace lcv::slam {

std::string LocalMapper::PrepareLineCloud() {
  server_cameras_.clear();
  for (const auto& [id, params] : map_.server_cameras()) server_cameras_[id] = MakeCamera(params);

  // Distances from the server keyframes to their lines bound how far a hidden point can be:
  // every line is at least its perpendicular distance away, and hidden points lie within a few
  // times the typical one (the equirectangular model has no image border to bound them).
  std::vector<double> perpendicular;
  for (const auto& [id, kf] : map_.server_keyframes()) {
    const Eigen::Vector3d center = kf.cam_from_world.Center();
    for (const Id line_id : kf.line_ids) {
      const SlamLine* line = map_.FindLine(line_id);
      if (line != nullptr) perpendicular.push_back(line->line.Distance(center));
    }
  }
  double max_distance = 0.0;
  if (!perpendicular.empty()) {
    const size_t k = perpendicular.size() * 95 / 100;
    std::nth_element(perpendicular.begin(), perpendicular.begin() + k, perpendicular.end());
    max_distance = kLineDistanceFactor * perpendicular[k];
  }

  int without_descriptor = 0, without_interval = 0, without_keyframes = 0;
  std::vector<Rigid3d> poses;
  std::vector<const Camera*> cameras;
  for (auto& [id, line] : map_.mutable_lines()) {
    without_descriptor += !line.descriptor.has_value();
    poses.clear();
    cameras.clear();
    for (const Id kf_id : line.server_keyframe_ids) {
      const SlamServerKeyframe* kf = map_.FindServerKeyframe(kf_id);
      if (kf == nullptr) continue;
      poses.push_back(kf->cam_from_world);
      cameras.push_back(server_cameras_.at(kf->camera_id).get());
    }
    line.has_interval = false;
    if (poses.empty() || !(max_distance > 0.0)) {
      ++without_keyframes;
      continue;
    }
    const std::optional<std::pair<double, double>> interval =
        LineVisibleInterval(line.line, poses, cameras, 0.0, max_distance);
    if (!interval) {
      ++without_interval;
      continue;
    }
    line.has_interval = true;
    line.s_min = interval->first;
    line.s_max = interval->second;
  }
  if (options_.vocabulary) {
    BuildServerKeyframeBow(*options_.vocabulary, &map_, &server_database_);
  }

  std::ostringstream problems;
  const int num_lines = static_cast<int>(map_.lines().size());
  if (map_.server_keyframes().empty()) {
    problems << "the line cloud has " << num_lines
             << " lines but no server keyframes: no line can be searched or relocalized against";
  } else if (without_descriptor == num_lines) {
    problems << "none of the " << num_lines
             << " lines has a descriptor: the client cannot match them";
  } else if (without_descriptor > 0 || without_keyframes > 0) {
    problems << without_descriptor << " of " << num_lines << " lines have no descriptor, "
             << without_keyframes << " are seen by no server keyframe (not matchable)";
  }
  (void)without_interval;  // lines no keyframe can image together are simply not searched
  return problems.str();
}

void LocalMapper::LoadLineCloud(SlamMap line_cloud) {
  Reset();
  map_ = std::move(line_cloud);
  LCV_CHECK(map_.keyframes().empty()) << "LoadLineCloud: the map has client keyframes";
}

void LocalMapper::UpdateLineCloudDetachment(Id keyframe_id) {
  // Only where line-cloud loops are closed: a correction is what attaches the map again.
  if (!options_.LoopClosingActive() || !options_.line_cloud.close_loops) return;
  const bool detached = slam::UpdateLineCloudDetachment(map_, keyframe_id, options_.line_cloud.loop,
                                                        &low_restored_streak_);
  if (detached && !map_.LineCloudDetached()) ++line_cloud_detachments_;
  map_.SetLineCloudDetached(detached);
}

void LocalMapper::TryRegisterInLineCloud(Id keyframe_id) {
  if (!map_.HasLineCloud() || map_.ActiveSegmentRegistered()) return;
  if (map_.server_keyframes().empty()) return;
  LineCloudRelocalizerOptions options = options_.line_cloud.relocalizer;
  const LineCloudRelocalizationReport report =
      RelocalizeInLineCloud(options_.vocabulary.get(), server_database_, keyframe_id, options,
                            options_.seed + keyframe_id, &map_);
  ++line_cloud_attempts_;
  last_line_cloud_report_ = report;
  if (static_cast<int>(line_cloud_attempt_log_.size()) < SystemStats::kMaxLineCloudAttemptLog) {
    SystemStats::LineCloudAttempt attempt;
    attempt.keyframe_id = keyframe_id;
    const SlamKeyframe* keyframe = map_.FindKeyframe(keyframe_id);
    attempt.timestamp = keyframe != nullptr ? keyframe->timestamp : 0.0;
    attempt.candidates = report.num_candidates;
    attempt.lines = report.num_lines;
    attempt.point_line_matches = report.registration.num_point_line_matches;
    attempt.point_point_matches = report.registration.num_point_point_matches;
    attempt.inliers = report.registration.num_inliers;
    attempt.method = report.registration.method;
    attempt.success = report.success;
    attempt.failure = report.failure;
    attempt.time_ms = report.time_ms;
    line_cloud_attempt_log_.push_back(std::move(attempt));
  }
  if (!report.success) {
    TryRegisterFromViews(keyframe_id);
    return;
  }
  ++line_cloud_registrations_;
  // Everything local mapping remembers of the segment's geometry moved with it; the snapshot
  // is rebuilt around the keyframe (Publish, by the caller's normal path).
}

namespace {

// The client points X seen at p6L inlier keypoints of a view registration's agreeing views, as
// X' on their lines (as P4L's inliers become X'): those the registration puts within max_angle
// (radians, seen from the keyframe) of the line, at the foot of S X on it.
std::vector<LineCloudRegistration::RestoredPoint> RestoredFromViews(
    const SlamMap& map, const std::vector<LineCloudView>& views,
    const LineCloudViewRegistration& registration, double max_angle) {
  const Sim3d& server_from_client = registration.server_from_client;
  const double max_sin = std::sin(max_angle);
  std::vector<LineCloudRegistration::RestoredPoint> restored;
  for (const LineCloudView& view : views) {
    if (std::find(registration.view_keyframe_ids.begin(), registration.view_keyframe_ids.end(),
                  view.keyframe_id) == registration.view_keyframe_ids.end()) {
      continue;
    }
    const SlamKeyframe& kf = *map.FindKeyframe(view.keyframe_id);
    const Eigen::Vector3d centre = server_from_client * kf.Center();
    for (const auto& [keypoint, line_id] : view.matches) {
      const Id landmark_id = kf.landmark_ids[keypoint];
      const SlamLandmark* landmark = map.FindLandmark(landmark_id);
      const SlamLine* line = map.FindLine(line_id);
      if (landmark == nullptr || line == nullptr || landmark->IsRestored()) continue;
      const Eigen::Vector3d point = server_from_client * landmark->position_in_world;
      const double distance = (point - centre).norm();
      if (!(distance > 0.0) || line->line.Residual(point).norm() > max_sin * distance) continue;
      restored.push_back({landmark_id, line_id, line->line.Project(point)});
    }
  }
  return restored;
}

}  // namespace

void LocalMapper::TryRegisterFromViews(Id keyframe_id) {
  const LineCloudViewRegistrationOptions& options = options_.line_cloud.view_registration;
  const SlamKeyframe* keyframe = map_.FindKeyframe(keyframe_id);
  if (!options.enabled || line_cloud_localizer_ == nullptr || keyframe == nullptr) return;
  if (keyframe->segment != line_cloud_views_segment_) {
    line_cloud_views_.clear();
    line_cloud_views_segment_ = keyframe->segment;
    line_cloud_view_localizations_ = 0;
  }
  if (line_cloud_view_localizations_ >= options.max_keyframes_per_segment) return;
  ++line_cloud_view_localizations_;
  const auto start = std::chrono::steady_clock::now();
  const LineCloudLocalization located =
      line_cloud_localizer_->Localize(keyframe->keypoints, keyframe->descriptors,
                                      options.max_ransac_trials);
  if (located.success && located.num_inliers >= options.min_view_inliers) {
    LineCloudView view;
    view.keyframe_id = keyframe_id;
    view.matches = located.inliers;
    view.server_cam_from_world = located.cam_from_world;
    view.bearings = located.inlier_bearings;
    view.lines = located.inlier_lines;
    line_cloud_views_.push_back(std::move(view));
    if (static_cast<int>(line_cloud_views_.size()) > options.max_views) {
      line_cloud_views_.erase(line_cloud_views_.begin());
    }
  }
  // The client poses as they are now (local BA moved them since), of keyframes still in the map.
  std::vector<LineCloudView> views;
  for (const LineCloudView& view : line_cloud_views_) {
    const SlamKeyframe* kf = map_.FindKeyframe(view.keyframe_id);
    if (kf == nullptr || kf->segment != line_cloud_views_segment_) continue;
    views.push_back(view);
    views.back().client_cam_from_world = kf->cam_from_world;
  }
  LineCloudViewRegistrationOptions solve_options = options;
  if (!(solve_options.max_error_rad > 0.0)) {
    solve_options.max_error_rad = line_cloud_localizer_->max_error_rad();
  }
  const LineCloudViewRegistration registration = RegisterFromViews(views, solve_options);
  const double time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  // The keyframe's record of its P4L / P3P attempt (TryRegisterInLineCloud) says this too.
  if (!line_cloud_attempt_log_.empty() &&
      line_cloud_attempt_log_.back().keyframe_id == keyframe_id) {
    SystemStats::LineCloudAttempt& attempt = line_cloud_attempt_log_.back();
    attempt.views = static_cast<int>(views.size());
    attempt.views_failure = located.success ? registration.failure : "p6L: " + located.failure;
    attempt.views_ms = time_ms;
    if (registration.success) {
      attempt.success = true;
      attempt.method = "p6l-views";
      attempt.inliers = registration.num_inliers;
      attempt.views_failure.clear();
    }
  }
  if (!registration.success) return;
  LineCloudRegistration applied;
  applied.success = true;
  applied.server_from_client = registration.server_from_client;
  applied.method = "p6l-views";
  applied.num_inliers = registration.num_inliers;
  applied.restored =
      RestoredFromViews(map_, views, registration,
                        kRestoreFromViewsMaxAngleFactor * solve_options.max_error_rad);
  ApplyLineCloudRegistration(applied, registration.view_keyframe_ids, &map_);
  line_cloud_views_.clear();
  ++line_cloud_registrations_;
  last_line_cloud_report_ = LineCloudRelocalizationReport();
  last_line_cloud_report_.success = true;
  last_line_cloud_report_.keyframe_id = keyframe_id;
  last_line_cloud_report_.registration = applied;
  last_line_cloud_report_.view_keyframe_ids = registration.view_keyframe_ids;
  last_line_cloud_report_.time_ms = time_ms;
}

}  // namespace lcv::slam
