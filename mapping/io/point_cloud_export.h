#pragma once
// Export of a map's geometry for CloudCompare, MeshLab, ParaView: PLY and PCD, written by hand
// (no PCL in this module) and atomically (temporary file + rename).
//
// What is written (world frame, map units):
// - every point landmark X as a vertex (white);
// - every line landmark as a segment of length line_length centred on its anchor (orange):
//     PLY: its two end vertices plus an `edge` element joining them (CloudCompare, ParaView);
//     PCD: a polyline of samples_per_line vertices along the segment (PCD has no edges);
// - with include_cameras, every keyframe and server keyframe centre as a vertex (red).
// Restored points X' are never exported (they belong to a client, see slam/data/map.h).
// A line is infinite and its anchor is not where the hidden point was (mapping/line_cloud.h):
// the segments show directions and spread, not the scene's surfaces.
//
// Vertex layout, both formats: x, y, z as float32 and an RGB colour (PLY: three uchar properties
// red, green, blue; PCD: PCL's packed `rgb` float field).

#include <optional>
#include <string>

#include "slam/data/map.h"

namespace lcv::mapping {

enum class PointCloudFormat { kPly, kPcd };

// ".ply" -> PLY, ".pcd" -> PCD (case-insensitive); empty for anything else.
std::optional<PointCloudFormat> PointCloudFormatForPath(const std::string& path);

struct PointCloudExportOptions {
  bool ascii = false;  // ASCII instead of binary (little-endian) data
  // Length of each line's segment, map units; <= 0 picks 2% of the diagonal of the bounding box
  // of the points, anchors and camera centres (1 if that box is empty or flat).
  double line_length = 0.0;
  int samples_per_line = 16;  // PCD only; >= 2
  bool include_cameras = false;
};

struct PointCloudExportSummary {
  std::size_t vertices = 0;
  std::size_t edges = 0;     // PLY only
  double line_length = 0.0;  // the segment length used
};

// Precondition: options.samples_per_line >= 2 (checked, std::logic_error).
std::string SerializePly(const slam::Map& map, const PointCloudExportOptions& options,
                         PointCloudExportSummary* summary = nullptr);
std::string SerializePcd(const slam::Map& map, const PointCloudExportOptions& options,
                         PointCloudExportSummary* summary = nullptr);

// Format from the extension of path. Throws lcv::InputError for another extension or when the
// file cannot be written.
PointCloudExportSummary ExportPointCloud(const slam::Map& map, const std::string& path,
                                         const PointCloudExportOptions& options);

}  // namespace lcv::mapping
