#pragma once
// Two maps of one scene compared entity by entity (COLMAP's model_comparer for lcv maps): how far
// `lcv map optimize`, a merge, a client's global BA or a SLAM run moved each keyframe, point and
// line against a reference (the map before, or a ground-truth map).
//
// Entities are matched by id: ids are unique map-wide and survive every step of the project
// (`lcv map convert` gives a point's line and a keyframe's server keyframe the same id, merges
// and optimizations keep them). So a SLAM point map compares with the line cloud published from
// it, and a line cloud with the same cloud after optimization.
//
// - Poses: client and server keyframes of one id, whatever their kind in each map: the distance
//   between the camera centres and the angle between the rotations.
// - Structure, by kinds (reference -> map):
//     point -> point: distance between the points;
//     point -> line:  distance of the reference point from the map's line (0 when the line was
//                     published from that point and not moved since);
//     line -> point:  distance of the map's point from the reference line;
//     line -> line:   distance of the reference line's anchor from the map's line, and the angle
//                     between their directions (0-90 degrees).
// - Restored points X' of the map's lines: distance to the reference's point of the same id
//   (the point the line hides), or to the reference line's own X'.
//
// Alignment (optional): the map is first moved onto the reference by the similarity of their
// common keyframes (slam::AlignMapDatum: the centres' fit where they span a plane, the cameras'
// rotations where they lie along a street), so that a map in another frame or scale compares.

#include <optional>
#include <string>
#include <vector>

#include "mapping/eval/trajectory_error.h"
#include "slam/data/map.h"
#include "slam/geometry/sim3.h"

namespace lcv::mapping {

struct MapCompareOptions {
  bool align = false;  // move the map onto the reference by its common keyframes first
};

struct PoseDifference {
  slam::Id id = slam::kInvalidId;
  bool server_in_reference = false;  // a server keyframe there (else a client keyframe)
  bool server_in_map = false;
  double position_m = 0.0;
  double rotation_deg = 0.0;
};

enum class StructurePair { kPointPoint, kPointLine, kLinePoint, kLineLine };
const char* StructurePairName(StructurePair pair);  // "point-point", "point-line", ...

struct StructureDifference {
  slam::Id id = slam::kInvalidId;
  StructurePair pair = StructurePair::kPointPoint;
  double distance_m = 0.0;
  double angle_deg = 0.0;  // line -> line only
};

struct RestoredDifference {
  slam::Id id = slam::kInvalidId;  // the map's line
  double distance_m = 0.0;
};

struct MapComparison {
  // Set when the comparison cannot be made (alignment asked for and impossible); nothing else is
  // filled then.
  std::optional<std::string> problem;
  bool aligned = false;
  slam::Sim3d reference_from_map;  // identity unless aligned

  int poses_only_in_reference = 0;
  int poses_only_in_map = 0;
  int structure_only_in_reference = 0;  // points and lines
  int structure_only_in_map = 0;
  std::vector<PoseDifference> poses;           // by id
  std::vector<StructureDifference> structure;  // by id
  std::vector<RestoredDifference> restored;    // by id

  ErrorStatistics pose_position_m;
  ErrorStatistics pose_rotation_deg;
  // One per StructurePair, indexed by its value.
  ErrorStatistics structure_distance_m[4];
  ErrorStatistics line_angle_deg;
  ErrorStatistics restored_distance_m;
};

MapComparison CompareMaps(const slam::Map& reference, const slam::Map& map,
                          const MapCompareOptions& options);

}  // namespace lcv::mapping
