#include "slam/module/loop_detector.h"

#include <algorithm>
#include <limits>
#include <map>
#include <tuple>

#include "slam/match/keyframe_projection_matcher.h"
#include "slam/match/projection_matcher.h"
#include "slam/optimize/sim3_reprojection.h"
#include "slam/solve/ransac.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// The direct index restricted to features that hold a landmark (ORB-SLAM's SearchByBoW only
// compares features with map points, so the ratio test runs among those).
DirectIndex LandmarkDirectIndex(const SlamMap& map, const SlamKeyframe& kf) {
  DirectIndex out;
  for (const DirectIndexEntry& entry : kf.direct_index) {
    DirectIndexEntry kept;
    kept.node = entry.node;
    for (const int i : entry.features) {
      if (kf.landmark_ids[i] != kInvalidId && map.FindLandmark(kf.landmark_ids[i]) != nullptr) {
        kept.features.push_back(i);
      }
    }
    if (!kept.features.empty()) out.push_back(std::move(kept));
  }
  return out;
}

// ORB-SLAM's rotation-consistency check of SearchByBoW: the keypoint angle changes of the
// matches are histogrammed and only matches in the three dominant bins stay; matches where an
// angle is unknown (< 0) are not binned and stay.
void KeepDominantRotations(const SlamKeyframe& a, const SlamKeyframe& b,
                           std::vector<DescriptorMatch>* matches) {
  constexpr int kBins = 30;
  std::vector<std::vector<int>> bins(kBins);
  for (size_t k = 0; k < matches->size(); ++k) {
    const float from = a.keypoints[(*matches)[k].index_a].angle_deg;
    const float to = b.keypoints[(*matches)[k].index_b].angle_deg;
    if (from < 0.f || to < 0.f) continue;
    bins[RotationBin(from, to, kBins)].push_back(static_cast<int>(k));
  }
  const std::vector<unsigned char> dominant = DominantRotationBins(bins);
  std::vector<char> drop(matches->size(), 0);
  for (int bin = 0; bin < kBins; ++bin) {
    if (dominant[bin]) continue;
    for (const int k : bins[bin]) drop[k] = 1;
  }
  std::vector<DescriptorMatch> kept;
  for (size_t k = 0; k < matches->size(); ++k) {
    if (!drop[k]) kept.push_back((*matches)[k]);
  }
  *matches = std::move(kept);
}

Sim3Correspondence MakeCorrespondence(const SlamMap& map, const SlamKeyframe& a, int index_a,
                                      const SlamKeyframe& b, int index_b) {
  Sim3Correspondence c;
  c.point_in_a = a.cam_from_world * map.FindLandmark(a.landmark_ids[index_a])->position_in_world;
  c.point_in_b = b.cam_from_world * map.FindLandmark(b.landmark_ids[index_b])->position_in_world;
  const Keypoint& kp_a = a.keypoints[index_a];
  const Keypoint& kp_b = b.keypoints[index_b];
  c.px_a = Eigen::Vector2d(kp_a.x, kp_a.y);
  c.px_b = Eigen::Vector2d(kp_b.x, kp_b.y);
  c.information_a = a.scale_levels.InverseSigma2(kp_a.octave);
  c.information_b = b.scale_levels.InverseSigma2(kp_b.octave);
  return c;
}

// For each landmark-bearing keypoint of `from` with no entry in from_matched (< 0), the nearest
// landmark-bearing keypoint of `to` by descriptor around the landmark's projection with
// to_from_from (ORB-SLAM's SearchBySim3, one direction). scale_to_own: factor from distances in
// `to`'s camera units to the landmark's own units. Writes best[i] (-1 when none).
void SearchOneWay(const SlamMap& map, const SlamKeyframe& from, const SlamKeyframe& to,
                  const Sim3d& to_from_from, const std::vector<int>& from_matched,
                  const LoopDetectorOptions& options, std::vector<int>* best) {
  best->assign(from.keypoints.size(), -1);
  std::vector<int> window;
  const double scale_to_own = 1.0 / to_from_from.scale;
  for (size_t i = 0; i < from.keypoints.size(); ++i) {
    if (from_matched[i] >= 0) continue;
    const SlamLandmark* landmark = map.FindLandmark(from.landmark_ids[i]);
    if (landmark == nullptr) continue;
    const Eigen::Vector3d p_in_to =
        to_from_from * (from.cam_from_world * landmark->position_in_world);
    const double own_distance = p_in_to.norm() * scale_to_own;
    if (!(own_distance > 0.0) || own_distance < 0.8 * landmark->min_distance ||
        own_distance > 1.2 * landmark->max_distance) {
      continue;
    }
    const std::optional<Eigen::Vector2d> px = to.camera->Project(p_in_to);
    if (!px || !to.camera->InImage(*px)) continue;
    const int octave = to.scale_levels.PredictOctave(own_distance, landmark->max_distance);
    const float radius =
        options.guided_radius_factor * static_cast<float>(to.scale_levels.Scale(octave));
    to.grid.Query(to.keypoints, static_cast<float>(px->x()), static_cast<float>(px->y()), radius,
                  std::max(0, octave - 1), octave, &window);
    int best_distance = options.guided_max_hamming_distance + 1;
    for (const int j : window) {
      if (to.landmark_ids[j] == kInvalidId) continue;
      const int d = HammingDistance(landmark->descriptor, to.descriptors[j]);
      if (d < best_distance) {
        best_distance = d;
        (*best)[i] = j;
      }
    }
  }
}

}  // namespace

LoopDetector::LoopDetector(const LoopDetectorOptions& options) : options_(options) {}

void LoopDetector::Reset() {
  consistent_groups_.clear();
  queries_since_reset_ = 0;
}

std::optional<LoopDetection> LoopDetector::Detect(const SlamMap& map, const BowDatabase& database,
                                                  Id keyframe_id, std::uint64_t seed) {
  last_attempt_ = LoopDetectionAttempt();
  last_attempt_.query_keyframe_id = keyframe_id;
  last_attempt_.skipped = true;
  const SlamKeyframe* query = map.FindKeyframe(keyframe_id);
  if (query == nullptr || query->bow.empty()) return std::nullopt;
  if (++queries_since_reset_ <= options_.min_keyframes_between_loops) return std::nullopt;
  last_attempt_.skipped = false;

  const std::vector<Id> candidates = DetectCandidates(map, database, *query);
  last_attempt_.num_candidates = static_cast<int>(candidates.size());
  if (candidates.empty()) {
    consistent_groups_.clear();
    return std::nullopt;
  }
  const std::vector<Id> consistent = CheckConsistency(map, candidates);
  last_attempt_.num_consistent = static_cast<int>(consistent.size());
  for (size_t k = 0; k < consistent.size(); ++k) {
    const SlamKeyframe* candidate = map.FindKeyframe(consistent[k]);
    if (candidate == nullptr) continue;
    LoopDetectionAttempt attempt = last_attempt_;
    attempt.best_candidate_id = candidate->id;
    std::optional<LoopDetection> loop = ComputeSim3(map, *query, *candidate, seed + k, &attempt);
    // Keep the candidate that got furthest (stages are nested, so compare stage by stage).
    const auto progress = [](const LoopDetectionAttempt& a) {
      return std::make_tuple(a.num_total_matches, a.num_refined_inliers, a.num_ransac_inliers,
                             a.num_bow_matches);
    };
    if (last_attempt_.best_candidate_id == kInvalidId ||
        progress(attempt) > progress(last_attempt_)) {
      last_attempt_ = attempt;
    }
    if (loop) {
      attempt.detected = true;
      last_attempt_ = attempt;
      queries_since_reset_ = 0;
      return loop;
    }
  }
  return std::nullopt;
}

std::vector<Id> LoopDetector::DetectCandidates(const SlamMap& map, const BowDatabase& database,
                                               const SlamKeyframe& query) const {
  std::vector<Id> excluded{query.id};
  double min_score = 1.0;
  for (const auto& [id, weight] : query.ordered_covisibles) {
    excluded.push_back(id);
    const SlamKeyframe* neighbour = map.FindKeyframe(id);
    if (neighbour != nullptr) min_score = std::min(min_score, BowL1Score(query.bow, neighbour->bow));
  }
  if (query.ordered_covisibles.empty()) return {};
  const std::vector<BowQueryResult> results = database.Query(query.bow, 0, excluded, 1);
  int max_shared = 0;
  for (const BowQueryResult& r : results) {
    if (map.FindKeyframe(r.keyframe_id) != nullptr) max_shared = std::max(max_shared, r.num_shared_words);
  }
  const double min_shared = options_.min_shared_words_ratio * max_shared;
  // Keyframes sharing enough words (their scores count in the groups), and the candidates among
  // them that also reach min_score.
  std::map<Id, double> score_of;
  std::vector<BowQueryResult> passing;
  for (const BowQueryResult& r : results) {
    if (r.num_shared_words < min_shared || map.FindKeyframe(r.keyframe_id) == nullptr) continue;
    score_of[r.keyframe_id] = r.score;
    if (r.score >= min_score) passing.push_back(r);
  }
  if (passing.empty()) return {};

  std::vector<std::pair<double, Id>> groups;  // (accumulated score, best keyframe)
  double best_accumulated = 0.0;
  for (const BowQueryResult& r : passing) {
    double accumulated = r.score;
    double best_score = r.score;
    Id best = r.keyframe_id;
    for (const Id neighbour : map.CovisibleKeyframes(r.keyframe_id, options_.group_size)) {
      auto it = score_of.find(neighbour);
      if (it == score_of.end()) continue;
      accumulated += it->second;
      if (it->second > best_score) {
        best_score = it->second;
        best = neighbour;
      }
    }
    groups.emplace_back(accumulated, best);
    best_accumulated = std::max(best_accumulated, accumulated);
  }
  std::vector<Id> out;
  for (const auto& [accumulated, id] : groups) {
    if (accumulated < options_.min_group_score_ratio * best_accumulated) continue;
    if (std::find(out.begin(), out.end(), id) == out.end()) out.push_back(id);
  }
  return out;
}

std::vector<Id> LoopDetector::CheckConsistency(const SlamMap& map,
                                               const std::vector<Id>& candidates) {
  std::vector<Id> enough;
  std::vector<ConsistentGroup> current;
  std::vector<char> previous_extended(consistent_groups_.size(), 0);
  for (const Id candidate : candidates) {
    ConsistentGroup group;
    group.keyframes.insert(candidate);
    for (const Id id : map.CovisibleKeyframes(candidate, std::numeric_limits<int>::max())) {
      group.keyframes.insert(id);
    }
    bool consistent_for_some = false;
    bool enough_consistent = false;
    for (size_t g = 0; g < consistent_groups_.size(); ++g) {
      const std::set<Id>& previous = consistent_groups_[g].keyframes;
      bool shared = false;
      for (const Id id : group.keyframes) {
        if (previous.count(id)) {
          shared = true;
          break;
        }
      }
      if (!shared) continue;
      consistent_for_some = true;
      const int consistency = consistent_groups_[g].consistency + 1;
      if (!previous_extended[g]) {
        current.push_back({group.keyframes, consistency});
        previous_extended[g] = 1;
      }
      if (consistency >= options_.consistency_threshold && !enough_consistent) {
        enough.push_back(candidate);
        enough_consistent = true;
      }
    }
    if (!consistent_for_some) current.push_back({group.keyframes, 0});
  }
  consistent_groups_ = std::move(current);
  return enough;
}

std::optional<LoopDetection> LoopDetector::ComputeSim3(const SlamMap& map,
                                                       const SlamKeyframe& query,
                                                       const SlamKeyframe& candidate,
                                                       std::uint64_t seed,
                                                       LoopDetectionAttempt* attempt) const {
  LCV_CHECK(query.camera != nullptr && candidate.camera != nullptr);
  // 1. BoW matches between landmark-bearing keypoints.
  std::vector<DescriptorMatch> bow_matches;
  MatchByDirectIndex(LandmarkDirectIndex(map, query), query.descriptors,
                     LandmarkDirectIndex(map, candidate), candidate.descriptors,
                     options_.bow_matching, &bow_matches);
  if (options_.check_orientation) KeepDominantRotations(query, candidate, &bow_matches);
  attempt->num_bow_matches = static_cast<int>(bow_matches.size());
  if (static_cast<int>(bow_matches.size()) < options_.min_bow_matches) return std::nullopt;
  std::vector<Sim3Correspondence> correspondences;
  std::vector<std::pair<int, int>> pairs;  // (query keypoint, candidate keypoint)
  for (const DescriptorMatch& m : bow_matches) {
    if (query.landmark_ids[m.index_a] == candidate.landmark_ids[m.index_b]) continue;
    correspondences.push_back(MakeCorrespondence(map, query, m.index_a, candidate, m.index_b));
    pairs.emplace_back(m.index_a, m.index_b);
  }
  if (static_cast<int>(correspondences.size()) < options_.min_bow_matches) return std::nullopt;

  // 2. RANSAC on reprojection in both images.
  const Sim3ReprojectionEstimator estimator(*query.camera, *candidate.camera, correspondences);
  RansacOptions ransac;
  ransac.max_error = std::sqrt(options_.ransac_chi2);
  ransac.min_inlier_ratio = 0.0;
  ransac.confidence = options_.ransac_confidence;
  ransac.max_num_trials = options_.ransac_max_trials;
  ransac.random_seed = seed;
  const RansacReport<Sim3d> report = Ransac(ransac, estimator);
  attempt->num_ransac_inliers = report.success ? report.num_inliers : 0;
  if (!report.success || report.num_inliers < options_.min_sim3_inliers) return std::nullopt;
  Sim3d query_from_candidate = report.model;

  // 3. Guided matching: keep the RANSAC inliers, add mutual projection matches.
  std::vector<int> query_match(query.keypoints.size(), -1);
  std::vector<int> candidate_match(candidate.keypoints.size(), -1);
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (!report.inlier_mask[k]) continue;
    query_match[pairs[k].first] = pairs[k].second;
    candidate_match[pairs[k].second] = pairs[k].first;
  }
  std::vector<int> best_in_candidate, best_in_query;
  SearchOneWay(map, query, candidate, query_from_candidate.Inverse(), query_match, options_,
               &best_in_candidate);
  SearchOneWay(map, candidate, query, query_from_candidate, candidate_match, options_,
               &best_in_query);
  for (size_t i = 0; i < query.keypoints.size(); ++i) {
    const int j = best_in_candidate[i];
    if (j < 0 || best_in_query[j] != static_cast<int>(i)) continue;
    if (query.landmark_ids[i] == candidate.landmark_ids[j]) continue;
    query_match[i] = j;
    candidate_match[j] = static_cast<int>(i);
  }
  correspondences.clear();
  pairs.clear();
  for (size_t i = 0; i < query.keypoints.size(); ++i) {
    if (query_match[i] < 0) continue;
    correspondences.push_back(
        MakeCorrespondence(map, query, static_cast<int>(i), candidate, query_match[i]));
    pairs.emplace_back(static_cast<int>(i), query_match[i]);
  }

  // 4. Refinement on the reprojection errors.
  Sim3RefineOptions refine;
  refine.chi2_threshold = options_.refine_chi2;
  const Sim3RefineReport refined = RefineSim3Reprojection(
      *query.camera, *candidate.camera, correspondences, refine, &query_from_candidate);
  attempt->num_refined_inliers = refined.num_inliers;
  if (refined.num_inliers < options_.min_sim3_inliers) return std::nullopt;

  LoopDetection loop;
  loop.query_keyframe_id = query.id;
  loop.match_keyframe_id = candidate.id;
  loop.num_inliers = refined.num_inliers;
  loop.corrected_query_cam_from_world = query_from_candidate * Sim3d(candidate.cam_from_world);

  // 5. The candidate's covisible group projected into the query at the corrected pose.
  std::vector<char> blocked(query.keypoints.size(), 0);
  std::set<Id> found;
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (!refined.inlier_mask[k]) continue;
    const Id landmark_id = candidate.landmark_ids[pairs[k].second];
    loop.matches.emplace_back(pairs[k].first, landmark_id);
    blocked[pairs[k].first] = 1;
    found.insert(landmark_id);
  }
  std::vector<Id> group{candidate.id};
  for (const Id id : map.CovisibleKeyframes(candidate.id, std::numeric_limits<int>::max())) {
    group.push_back(id);
  }
  std::vector<Id> loop_landmarks;
  std::set<Id> listed;
  for (const Id kf_id : group) {
    const SlamKeyframe* kf = map.FindKeyframe(kf_id);
    if (kf == nullptr) continue;
    for (const Id landmark_id : kf->landmark_ids) {
      if (landmark_id == kInvalidId || found.count(landmark_id)) continue;
      if (listed.insert(landmark_id).second) loop_landmarks.push_back(landmark_id);
    }
  }
  KeyframeProjectionOptions projection;
  projection.radius_factor = options_.projection_radius_factor;
  for (const KeyframeProjectionMatch& m : MatchLandmarksIntoKeyframe(
           map, query, loop.corrected_query_cam_from_world, loop_landmarks, projection,
           &blocked)) {
    loop.matches.emplace_back(m.keypoint_index, m.landmark_id);
  }
  attempt->num_total_matches = static_cast<int>(loop.matches.size());
  if (static_cast<int>(loop.matches.size()) < options_.min_total_matches) return std::nullopt;
  std::sort(loop.matches.begin(), loop.matches.end());
  return loop;
}

}  // namespace lcv::slam
