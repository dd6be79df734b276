#pragma once
// Relocalization of the client's map in the server's line cloud (paper Sec. 3.2), run by local
// mapping (the map's one writer) on each new keyframe until it succeeds:
//
// 1. candidate server keyframes: BoW of the keyframe against the server keyframes' BoW vectors,
//    made from the descriptors of the lines they see (server keyframes have no keypoints; their
//    database is apart from the client keyframes', so ordinary relocalization and loop
//    detection never see them); without a vocabulary every server keyframe is a candidate;
// 2. the keyframe's local 3D points X_ckf (the points it observes, with their observations in it
//    and its best covisible keyframes) against the candidates' lines, and against the X' already
//    restored on those lines (server-frame points: a map lost and restarted after an earlier
//    registration), registered by RegisterToLineCloud (slam/module/line_cloud_registration.h:
//    P4L or P3P Sim(3) RANSAC by the paper's rule, then the rigid-stereo BA of eq. 7);
// 3. on success the whole active segment is moved into the server's frame and scale
//    (SlamMap::MoveSegment), marked registered, and the inlier points become X' on their lines
//    at their rigid-stereo BA positions. When another segment is already registered (the client
//    was lost and restarted), the two are in one frame now and are joined.
//
// Thread safety: needs exclusive access to the map (the caller is its writer).

#include <cstdint>
#include <string>
#include <set>
#include <vector>

#include "slam/bow/bow_database.h"
#include "slam/bow/vocabulary.h"
#include "slam/data/slam_map.h"
#include "slam/geometry/sim3.h"
#include "slam/module/line_cloud_registration.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct LineCloudRelocalizerOptions {
  int max_candidates = 5;  // server keyframes by BoW score; their lines are matched
  // What the keyframe's BoW query is made of. A server keyframe's BoW comes from the
  // descriptors of the lines it sees, i.e. of the map points the server triangulated, a few
  // hundred of its features; the keyframe's own BoW vector holds all its keypoints (2000),
  // most of them never triangulated. true: query with the descriptors of the keyframe's
  // landmarks instead (what the client triangulated), like with like. Measured in
  // docs/benchmarks-lcvslam.md ("Relocalization candidates").
  bool query_from_landmarks = true;
  // Candidates by votes: the vote_pool best server keyframes by BoW score are re-ranked by how
  // many of the keyframe's landmark descriptors have their nearest line (within
  // vote_max_hamming_distance) among the lines each sees, and the max_candidates with the most
  // votes are kept. The BoW score alone cannot tell places apart in a scene whose textures
  // repeat (measured in docs/benchmarks-lcvslam.md, "Relocalization candidates"). Cost:
  // landmarks x lines of the pool Hamming distances (~200 x 2500 ~ 1 ms). 0: BoW score only.
  int vote_pool = 20;
  int vote_max_hamming_distance = 50;
  int max_views = 5;       // the keyframe and its best covisible keyframes (rigid-stereo BA)
  LineCloudRegistrationOptions registration;
};

struct LineCloudRelocalizationReport {
  bool success = false;
  std::string failure;  // why not, when !success
  Id keyframe_id = kInvalidId;
  int num_candidates = 0;  // server keyframes whose lines were matched
  int num_lines = 0;       // candidate lines
  LineCloudRegistration registration;
  std::vector<Id> view_keyframe_ids;  // the keyframe and the covisibles of the rigid-stereo BA
  double time_ms = 0.0;
};

// Which server keyframes and server points step 1-2 may use.
struct LineCloudMatchScope {
  std::set<Id> excluded;  // server keyframes never taken as candidates
  // Also match the keyframe's points against the X' of its own (registered) segment, as points
  // already in the server frame (loop closing: the client returns to lines it restored before).
  bool restored_of_active_segment = false;
  // X_ckf: the points of all the views (the keyframe and its best covisibles) instead of the
  // keyframe's own.
  bool points_of_all_views = false;
};

// BoW vectors and direct indices of every server keyframe from its lines' descriptors, and a
// database of them. No-op (database cleared) with an empty vocabulary.
void BuildServerKeyframeBow(const Vocabulary& vocabulary, SlamMap* map,
                            BowDatabase* server_database);

// The server keyframes whose lines step 2 matches (step 1), from a query of the server
// database (all results, best score first) and the keyframe's landmark descriptors: see
// LineCloudRelocalizerOptions::vote_pool.
std::vector<Id> SelectServerCandidates(const SlamMap& map,
                                       const std::vector<BowQueryResult>& results,
                                       const std::vector<OrbDescriptor>& query_descriptors,
                                       const LineCloudRelocalizerOptions& options);

// Steps 1-2 only: the map is not changed (success: report.registration holds the Sim(3) and
// the inlier matches). Reads the map only.
LineCloudRelocalizationReport MatchKeyframeToLineCloud(
    const Vocabulary* vocabulary, const BowDatabase& server_database, Id keyframe_id,
    const LineCloudRelocalizerOptions& options, const LineCloudMatchScope& scope,
    std::uint64_t seed, const SlamMap& map);

// Step 3 alone, for a registration found another way (slam/module/line_cloud_view_registration.h):
// the active segment moved by registration.server_from_client, its `restored` inliers made X',
// joined with a segment registered before; view_ids: the keyframes whose covisibility is renewed.
void ApplyLineCloudRegistration(const LineCloudRegistration& registration,
                                const std::vector<Id>& view_ids, SlamMap* map);

// Steps 1-3 for client keyframe keyframe_id of the active segment. The keyframe's BoW must be
// computed when a vocabulary is given (nullptr or empty: every server keyframe is a candidate).
// Changes the map only on success.
LineCloudRelocalizationReport RelocalizeInLineCloud(const Vocabulary* vocabulary,
                                                    const BowDatabase& server_database,
                                                    Id keyframe_id,
                                                    const LineCloudRelocalizerOptions& options,
                                                    std::uint64_t seed, SlamMap* map);

}  // namespace lcv::slam
