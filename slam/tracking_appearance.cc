// Tracker's prediction-free recovery (slam/tracking.h, step 3): the last frame's landmarks
// matched into the frame by descriptor alone, then P3P. Split from tracking.cc to keep files
// small.
#include <algorithm>
#include <cstdlib>
#include <limits>
#include <optional>
#include <vector>

#include "slam/match/projection_matcher.h"  // RotationBin, DominantRotationBins
#include "slam/tracking.h"

namespace lcv::slam {

int Tracker::TrackLastFrameByAppearance(const LocalMapSnapshot& snapshot, Frame* frame) {
  // ORB-SLAM's TrackReferenceKeyFrame matches by BoW, independent of any pose prediction; here
  // the last frame (which holds its reference keyframe's landmarks when it became one,
  // AdoptReferenceLandmarks) is matched exhaustively: a few hundred landmarks against the
  // frame's keypoints, octaves within +-2, ORB-SLAM's TH_LOW and ratio, and the orientation
  // histogram's dominant bins. The window-free search is what a turn that starts or stops
  // between two frames needs: the constant-velocity rotation is then wrong by the whole turn.
  frame->ResetMatches();
  const int num_keypoints = frame->num_keypoints();
  constexpr int kMaxDistance = 50;
  constexpr float kRatio = 0.75f;
  constexpr int kOctaveBand = 2;
  constexpr int kBins = 30;
  // Candidates: the last frame's matched keypoints (their own descriptor, octave and angle),
  // then the window's other landmarks that the last frame's camera had in its image (their
  // representative descriptor, predicted octave, no angle): a frame tracking few points in the
  // turn holds a fraction of what the map already has of the view.
  struct Candidate {
    Id landmark_id;
    const OrbDescriptor* descriptor;
    int octave;
    float angle_deg;  // < 0: unknown (not in the orientation histogram)
  };
  std::vector<Candidate> candidates;
  std::vector<Id> taken;
  for (int i = 0; i < last_frame_.num_keypoints(); ++i) {
    const Id id = last_frame_.landmark_ids[i];
    if (id == kInvalidId || last_frame_.is_outlier[i]) continue;
    if (snapshot.FindLandmark(id) == nullptr) continue;
    candidates.push_back({id, &last_frame_.descriptors[i], last_frame_.keypoints[i].octave,
                          last_frame_.keypoints[i].angle_deg});
    taken.push_back(id);
  }
  std::sort(taken.begin(), taken.end());
  const Camera& camera = *frame->camera;
  for (const SnapshotLandmark& landmark : snapshot.landmarks) {
    if (std::binary_search(taken.begin(), taken.end(), landmark.id)) continue;
    const Eigen::Vector3d p_in_last = last_frame_.cam_from_world * landmark.position_in_world;
    const std::optional<Eigen::Vector2d> px = camera.Project(p_in_last);
    if (!px || !camera.InImage(*px)) continue;
    const int octave =
        last_frame_.scale_levels.PredictOctave(p_in_last.norm(), landmark.max_distance);
    candidates.push_back({landmark.id, &landmark.descriptor, octave, -1.f});
  }
  std::vector<int> best_distance(num_keypoints, std::numeric_limits<int>::max());
  std::vector<int> best_source(num_keypoints, -1);
  for (int c = 0; c < static_cast<int>(candidates.size()); ++c) {
    const Candidate& candidate = candidates[c];
    NearestTwo nearest;
    for (int j = 0; j < num_keypoints; ++j) {
      if (std::abs(frame->keypoints[j].octave - candidate.octave) > kOctaveBand) continue;
      nearest.Offer(HammingDistance(*candidate.descriptor, frame->descriptors[j]), j);
    }
    const int best = nearest.best, second = nearest.second, best_j = nearest.index;
    if (best_j < 0 || best > kMaxDistance || best >= kRatio * second) continue;
    // A frame keypoint claimed twice keeps the nearest.
    if (best < best_distance[best_j]) {
      best_distance[best_j] = best;
      best_source[best_j] = c;
    }
  }
  std::vector<std::vector<int>> bins(kBins);
  for (int j = 0; j < num_keypoints; ++j) {
    const int c = best_source[j];
    if (c < 0) continue;
    const float from = candidates[c].angle_deg;
    const float to = frame->keypoints[j].angle_deg;
    if (from < 0.f || to < 0.f) {
      frame->landmark_ids[j] = candidates[c].landmark_id;
      continue;
    }
    bins[RotationBin(from, to, kBins)].push_back(j);
  }
  const std::vector<unsigned char> dominant = DominantRotationBins(bins);
  for (int b = 0; b < kBins; ++b) {
    if (!dominant[b]) continue;
    for (const int j : bins[b]) frame->landmark_ids[j] = candidates[best_source[j]].landmark_id;
  }
  return PoseFromMatches(snapshot, frame);
}

}  // namespace lcv::slam
