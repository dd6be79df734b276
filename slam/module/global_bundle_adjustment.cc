#include "slam/module/global_bundle_adjustment.h"

#include <algorithm>
#include <map>
#include <set>


#include "slam/geometry/sim3.h"
#include "slam/optimize/residuals.h"
#include "slam/optimize/slam_map_bundle.h"
#include "slam/solve/umeyama.h"

namespace lcv::slam {
namespace {

// Moves a whole bundle by world2_from_world1 (a change of gauge: every residual of the problem
// but the metric part of e_pL is invariant, and that one changes by the scale factor only).
void TransformBundle(const Sim3d& world2_from_world1, BundleProblem* problem) {
  const Sim3d& S = world2_from_world1;
  for (BundleKeyframe& k : problem->keyframes) {
    k.cam_from_world = TransformPose(S, k.cam_from_world);
  }
  for (BundleServerKeyframe& k : problem->server_keyframes) {
    k.cam_from_world = TransformPose(S, k.cam_from_world);
  }
  for (BundlePoint& point : problem->points) point.position = S * point.position;
  for (BundleLine& line : problem->lines) {
    line.line = Line3d(S * line.line.anchor, (S.rotation * line.line.direction).normalized());
    line.restored_point = S * line.restored_point;
  }
}

// A datum (see CaptureGlobalBA): the similarity that takes the solved keyframes back onto their
// captured poses (AlignMapDatum: the centres' least-squares fit where they span a plane; where
// they lie along a street, whose centres leave the rotation about it to noise, the keyframes'
// rotations), applied to the whole job. False, and nothing moved, when AlignMapDatum finds none
// (fewer than 2 keyframes or all on one centre): the solve's own gauge stays.
bool RestoreDatum(const std::vector<Rigid3d>& solved, const std::vector<Rigid3d>& captured,
                  BundleProblem* problem) {
  Sim3d captured_from_solved;
  if (!AlignMapDatum(solved, captured, &captured_from_solved)) return false;
  TransformBundle(captured_from_solved, problem);
  return true;
}

}  // namespace

GlobalBAJob CaptureGlobalBA(const SlamMap& map, const GlobalBACaptureOptions& options) {
  GlobalBAJob job;
  job.num_loop_edges = map.loop_edges().size();
  SlamMapBundleBuilder builder(map, &job.problem);
  const bool line_cloud =
      options.free_line_cloud && map.HasLineCloud() && map.ActiveSegmentRegistered();
  // The active segment only: inactive ones are in frames of their own (slam_map.h).
  const int segment = map.active_segment();
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.segment == segment) {
      const int index =
          builder.AddKeyframe(id, /*fixed=*/!line_cloud && id == map.first_keyframe_id());
      if (options.keep_loaded_datum && kf.loaded) {
        job.loaded_keyframes.push_back(index);
        job.loaded_poses.push_back(kf.cam_from_world);
      }
    }
  }
  for (const auto& [id, landmark] : map.landmarks()) {
    if (landmark.segment == segment) builder.AddLandmark(id);
  }
  job.links = builder.links();
  if (line_cloud) {
    // The builder makes a BundleLine for each X' only: without one, nothing ties the client to
    // the lines.
    if (!job.problem.lines.empty()) {
      LineCloudBundleOptions line_cloud_options;
      line_cloud_options.free_server_keyframes = options.free_server_keyframes;
      line_cloud_options.virtual_from_published = options.virtual_from_published;
      job.line_ids = AddLineCloudToBundle(map, line_cloud_options, &job.problem);
      job.line_cloud = true;
      job.keep_server_datum = options.free_server_keyframes && options.keep_server_datum;
    } else if (!job.problem.keyframes.empty()) {
      job.problem.keyframes.front().fixed = true;
    }
  }
  return job;
}

BundleReport SolveGlobalBA(const GlobalBAOptions& options, GlobalBAJob* job) {
  BundleOptions bundle;
  bundle.max_iterations = options.max_iterations;
  bundle.max_refine_iterations = options.max_iterations;
  bundle.refine_without_outliers = options.refine_without_outliers;
  bundle.num_threads = options.num_threads;
  bundle.virtual_sigma_rad = options.virtual_sigma_rad;
  if (options.derived_virtual_information) {
    for (BundleVirtualObservation& v : job->problem.virtual_observations) {
      const BundleLine& line = job->problem.lines[v.line];
      v.sqrt_information = VirtualObservationSqrtInformation(
          job->problem.server_keyframes[v.server_keyframe].cam_from_world, line.line,
          v.observed_normal, line.information, options.virtual_sigma_rad);
    }
  }
  std::vector<Rigid3d> captured_server_poses;
  for (const BundleServerKeyframe& k : job->problem.server_keyframes) {
    captured_server_poses.push_back(k.cam_from_world);
  }
  job->report = SolveBundleAdjustment(bundle, &job->problem);
  if (job->report.success && job->keep_server_datum) {
    // The server datum: every server keyframe of the job moved with it, all written back.
    std::vector<Rigid3d> solved;
    for (const BundleServerKeyframe& k : job->problem.server_keyframes) {
      solved.push_back(k.cam_from_world);
    }
    if (RestoreDatum(solved, captured_server_poses, &job->problem)) {
      for (BundleServerKeyframe& k : job->problem.server_keyframes) k.fixed = false;
    }
  } else if (job->report.success && !job->loaded_keyframes.empty()) {
    // The loaded map's datum (GlobalBACaptureOptions::keep_loaded_datum).
    std::vector<Rigid3d> solved;
    for (const int k : job->loaded_keyframes) {
      solved.push_back(job->problem.keyframes[k].cam_from_world);
    }
    RestoreDatum(solved, job->loaded_poses, &job->problem);
  }
  job->solved = true;
  return job->report;
}

bool ApplyGlobalBA(const GlobalBAJob& job, SlamMap* map) {
  if (!job.solved || !job.report.success) return false;
  if (map->loop_edges().size() != job.num_loop_edges) return false;
  std::map<Id, Rigid3d> optimized;
  for (const BundleKeyframe& k : job.problem.keyframes) optimized[k.id] = k.cam_from_world;

  // New poses: captured keyframes from the solve, the others through the spanning tree (parents
  // are older, so a walk from the first keyframe reaches every keyframe of the tree).
  std::map<Id, Rigid3d> before, after;
  for (const auto& [id, kf] : map->keyframes()) before[id] = kf.cam_from_world;
  std::vector<Id> stack;
  const Id root = map->first_keyframe_id();
  if (map->FindKeyframe(root) != nullptr) {
    auto it = optimized.find(root);
    after[root] = it != optimized.end() ? it->second : before.at(root);
    stack.push_back(root);
  }
  while (!stack.empty()) {
    const Id parent = stack.back();
    stack.pop_back();
    for (const Id child : map->FindKeyframe(parent)->child_ids) {
      if (map->FindKeyframe(child) == nullptr || after.count(child)) continue;
      auto it = optimized.find(child);
      after[child] = it != optimized.end()
                         ? it->second
                         : (before.at(child) * before.at(parent).Inverse()) * after.at(parent);
      stack.push_back(child);
    }
  }
  // Keyframes the tree does not reach (none in a consistent map) keep a captured value if any.
  for (const auto& [id, pose] : before) {
    if (after.count(id)) continue;
    auto it = optimized.find(id);
    after[id] = it != optimized.end() ? it->second : pose;
  }

  const std::vector<Id> written = WriteBackLandmarkPositions(job.problem, map);
  const std::set<Id> captured_points(written.begin(), written.end());
  for (auto& [id, landmark] : map->mutable_landmarks()) {
    if (captured_points.count(id)) continue;
    Id anchor = landmark.reference_keyframe_id;
    if (!before.count(anchor)) {
      anchor = landmark.observations.empty() ? kInvalidId
                                             : landmark.observations.front().keyframe_id;
    }
    if (!before.count(anchor)) continue;
    landmark.position_in_world =
        after.at(anchor).Inverse() * (before.at(anchor) * landmark.position_in_world);
  }
  for (const auto& [id, pose] : after) {
    Rigid3d& cam_from_world = map->FindKeyframe(id)->cam_from_world;
    cam_from_world = pose;
    cam_from_world.rotation.normalize();
  }

  std::set<Id> touched;
  for (size_t k = 0; k < job.problem.observations.size(); ++k) {
    if (!job.problem.observations[k].outlier) continue;
    const GlobalBAJob::Link& link = job.links[k];
    const SlamKeyframe* kf = map->FindKeyframe(link.keyframe_id);
    if (kf == nullptr || kf->landmark_ids[link.keypoint_index] != link.landmark_id) continue;
    const SlamLandmark* landmark = map->FindLandmark(link.landmark_id);
    if (landmark != nullptr) {
      for (const Observation& o : landmark->observations) touched.insert(o.keyframe_id);
    }
    map->RemoveObservation(link.landmark_id, link.keyframe_id, 2);
  }
  if (job.line_cloud) {
    WriteBackLineCloud(job.problem, job.line_ids, map);
    for (const Id id : job.line_ids) {
      SlamLine* line = map->FindLine(id);
      if (line != nullptr) line->reference_line = line->line;
    }
  }
  for (const auto& [id, landmark] : map->landmarks()) map->UpdateLandmarkGeometry(id);
  for (const Id id : touched) map->UpdateCovisibility(id);
  return true;
}

}  // namespace lcv::slam
