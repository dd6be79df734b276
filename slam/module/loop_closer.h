#pragma once
// Loop correction (ORB-SLAM2's LoopClosing::CorrectLoop and Optimizer::OptimizeEssentialGraph,
// Mur-Artal and Tardos, T-RO 2017, Sec. VI-D/E; Strasdat et al., RSS 2010, for the Sim(3) pose
// graph), as a function on a SlamMap: the caller holds whatever lock makes it the map's only
// writer for the duration (and stops/aborts local mapping and global BA as ORB-SLAM does).
//
// 1. The query's covisible neighbourhood (it and its covisibility neighbours) is corrected by
//    the loop's Sim(3): each keyframe keeps its pose relative to the query, and every landmark
//    they see moves (scale included) with one of them (its reference keyframe when that is in
//    the neighbourhood, else the first neighbour that sees it);
// 2. fusion: the loop matches are linked to the query (a query landmark at a matched keypoint is
//    replaced by the match side's one, SlamMap::ReplaceLandmark), then the landmarks of the
//    match keyframe and its covisibles are projected into every corrected keyframe and fused
//    the same way; covisibility is updated;
// 3. essential graph (Sim(3) pose graph, slam/optimize/pose_graph.h) over all keyframes of the
//    match's segment (SlamMap segments; query and match must share it):
//    spanning-tree edges, the map's earlier loop edges, covisibility edges of weight >= 100,
//    and the new loop connections (edges created by the fusion: the query-match one always,
//    others when their weight >= 100). Measurements: relative Sim(3) before the correction,
//    except between keyframes of the corrected neighbourhood and for the new loop connections,
//    which use the corrected poses (ORB-SLAM). The match keyframe is fixed;
// 4. poses are written back as rigid transforms (cam_from_world = [R | t / s]); every landmark
//    moves with its reference keyframe's correction (or the neighbourhood keyframe that
//    corrected it in step 1); landmark geometry is recomputed; the loop edge is added.
//
// Scale: monocular maps drift in scale; corrected keyframes take the scale of the match side.
//
// Failure: an unknown query or match keyframe returns success = false and leaves the map as it
// was. Otherwise the map satisfies every invariant of slam/data/slam_map.h afterwards.
// Scale bookkeeping: every keyframe's SlamKeyframe::scale is divided by its final Sim(3) scale,
// so that frames recorded against it rescale their offsets (slam/data/frame_anchor.h).

#include <map>
#include <set>
#include <utility>
#include <vector>

#include "slam/data/slam_map.h"
#include "slam/module/loop_detector.h"
#include "slam/optimize/pose_graph.h"

namespace lcv::slam {

struct LoopCloserOptions {
  float fuse_radius_factor = 4.f;        // ORB-SLAM's SearchAndFuse window (x octave scale, px)
  int min_essential_covisibility = 100;  // covisibility edges in the essential graph
  PoseGraphOptions pose_graph;           // 20 iterations (ORB-SLAM)
  // The loaded map's datum (LoopClosing.keep_loaded_datum): keyframes read from a map file
  // (SlamKeyframe::loaded) move with the correction like any other, and then the whole segment
  // is moved by the similarity that takes them back onto where they were before it
  // (AlignMapDatum: their centres' least-squares fit, or along a street their rotations' mean
  // and then their centres; at least 2). The map a client reuses is its reference frame (a
  // server map aligned to the ground truth, a map the user keeps extending): the loop may reshape
  // it but not move, turn or scale it as a whole, as global BA keeps a line cloud's server datum
  // (slam/module/global_bundle_adjustment.h). See docs/slam.md "Loops in a loaded map".
  bool keep_loaded_datum = false;
};

struct LoopCorrectionReport {
  bool success = false;
  int num_fused = 0;                // loop matches linked or replaced, step 2
  int num_keyframes_corrected = 0;  // the neighbourhood of step 1
  int num_edges = 0;                // essential graph
  PoseGraphReport pose_graph;
  double time_ms = 0.0;
};

LoopCorrectionReport CorrectLoop(const LoopDetection& loop, const LoopCloserOptions& options,
                                 SlamMap* map);

// The steps CorrectLoop is made of, shared with the loop correction against a server's line
// cloud (slam/module/line_cloud_loop.h), whose match side is the line cloud instead of a
// keyframe. Same locking as CorrectLoop.
//
// Step 1: the query and its covisible keyframes take the loop's pose (each keeps its pose
// relative to the query); every landmark they see moves with one of them (corrected_by).
struct NeighbourhoodCorrection {
  std::vector<Id> keyframes;  // the query first
  std::set<Id> keyframe_set;
  std::map<Id, Sim3d> non_corrected;  // cam_from_world before, per keyframe
  std::map<Id, Sim3d> corrected;      // after (the loop's scale)
  std::map<Id, Id> corrected_by;      // landmark -> the keyframe it moved with
};
NeighbourhoodCorrection CorrectNeighbourhood(Id query_id,
                                             const Sim3d& corrected_query_cam_from_world,
                                             SlamMap* map);
// Covisible keyframes of each keyframe, from the covisibility graph as it is.
std::map<Id, std::set<Id>> CovisibleSets(const std::vector<Id>& keyframes, const SlamMap& map);
// After a fusion: updates the neighbourhood's covisibility and returns, per neighbourhood
// keyframe, the keyframes outside it that became covisible (ORB-SLAM's LoopConnections).
std::map<Id, std::vector<Id>> NewLoopConnections(const NeighbourhoodCorrection& n,
                                                 const std::map<Id, std::set<Id>>& before,
                                                 SlamMap* map);
// Steps 3-4: the essential graph over the keyframes of `segment` (loop connections of at least
// min_essential_covisibility, or listed in loop_pairs), the keyframes in `fixed` held, solved;
// poses written back with their scale bookkeeping and every landmark moved with its keyframe.
void RelaxEssentialGraph(const NeighbourhoodCorrection& n,
                         const std::map<Id, std::vector<Id>>& loop_connections,
                         const std::vector<std::pair<Id, Id>>& loop_pairs,
                         const std::set<Id>& fixed, int segment,
                         const LoopCloserOptions& options, SlamMap* map,
                         LoopCorrectionReport* report);

// Map merging (SlamMap segments): when the loop's match lies in another segment than its query
// (a map kept after tracking was lost), moves the query's whole segment into the match's frame
// and scale by the similarity the detection estimated, so that the query sits at its corrected
// pose, and rewrites loop->corrected_query_cam_from_world to that pose: CorrectLoop then only
// fuses the two sides and relaxes the merged pose graph. Returns true when it merged; false
// (nothing changed) when both lie in one segment or a keyframe is unknown. Same locking as
// CorrectLoop.
bool MergeSegmentsForLoop(LoopDetection* loop, SlamMap* map);

}  // namespace lcv::slam
