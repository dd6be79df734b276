#pragma once
// The reverse of SlamMap::ToMap: rebuilds the SLAM-side map (slam_map.h) from a persistent map
// (map.h) so that a saved map can be tracked in and extended (`lcv slam --map-in MAP`).
//
// What is restored: every client keyframe with its id, timestamp, pose, keypoints and
// descriptors; bearings and keypoint grid computed with `camera` as PrepareFrame does; every
// point with at least one observation as a landmark with its id, position and observations
// (keypoint landmark_ids follow from them); the landmark's stored descriptor (else the
// representative one), mean viewing direction and scale-invariance range (UpdateLandmarkGeometry;
// first and reference keyframe = the keyframe of the first observation, which is the creating
// keyframe, or the reference after culling, in maps written by SlamMap::ToMap); covisibility of every keyframe and the
// spanning tree (parent = most covisible older keyframe, as local mapping builds it when
// keyframes arrive in id order). The first keyframe is the one with the smallest id. NewId()
// continues after map.NextFreeId().
//
// Loop edges between restored keyframes are restored (so they are never culled).
// Not restored: BoW vectors and direct indices (the caller owns the vocabulary: fill
// SlamKeyframe::bow / direct_index with Vocabulary::Transform at kDirectIndexLevel), source frame
// ids (kInvalidId), the erased-keyframe chain.
//
// Line clouds: lines (with SqrtInformation of Omega_L), server keyframes and their cameras are
// imported with their ids; each line's restored point X' with observations becomes a landmark
// with a fresh id restored on it (SlamMap::RestoreOnLine). A map with client keyframes and lines
// is in the line cloud's frame: its segment is marked registered. A line cloud without client
// keyframes is accepted (the client initializes on its own and registers into it).
//
// Failure: throws std::invalid_argument with a message naming the problem when the map cannot
// be used: neither client keyframes nor lines; a keyframe without descriptors ("keyframe 12 has 0 descriptors
// for 431 keypoints"); a keyframe whose camera is missing or differs from `camera` in model or
// image size; an observation of a missing keyframe or keypoint; two points on one keypoint; a
// point id equal to a keyframe id. A point observed twice by one keyframe keeps the first
// observation (SlamMap holds one per keyframe).
//
// Cost: linear in keypoints, and in observations times observations per point (covisibility
// counts, representative descriptors); ~0.12 s for 219 keyframes / 14k points (docs/
// relocalization.md). The result refers to `camera` (SlamKeyframe::camera), which must outlive
// it. Thread safety: a pure function of its inputs.

#include "slam/camera/camera.h"
#include "slam/data/frame.h"
#include "slam/data/map.h"
#include "slam/data/slam_map.h"

namespace lcv::slam {

// grid_cell_size_px: KeypointGrid cell size, as PrepareFrame's cell_size_px.
SlamMap ImportSlamMap(const Map& map, const Camera& camera, const ScaleLevels& scale_levels,
                      int grid_cell_size_px = 32);

}  // namespace lcv::slam
