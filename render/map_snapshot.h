#pragma once
// Offscreen snapshots of maps (slam/data/map.h) as PNG-ready images, in the conventions of the
// paper's figures: line cloud blue, reconstructed points X black, restored points X' orange,
// client keyframes green and server keyframes red (as camera frustums), their trajectories as
// polylines, loop edges highlighted in magenta; white background.
//
// Lines are drawn clipped to the map's bounding box (MapFrame below), never as short segments
// around where the hidden points were: a segment centred on the point would give it away.
//
// Views: kTop (orthographic, looking down the map's up axis), kOblique (perspective from above
// and aside, azimuth selectable: an orbit is a sequence of azimuths), kKeyframe (through a client
// or server keyframe's camera), kExplicit (a given camera and pose).
//
// Determinism: same map and options -> identical pixels (fixed draw order by id, no
// multisampling, OSMesa llvmpipe). Speed: a 100,000-line map at 1280x720 renders in well under a
// second (bench/bench_render.cc).
//
// Thread safety: a MapSnapshotRenderer is used by one thread at a time (it owns a GL context).

#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "slam/camera/camera.h"
#include "slam/data/map.h"
#include "slam/geometry/rigid3.h"

namespace lcv::render {

// An upright frame fitted to the map's content (points, restored points, keyframe centres and,
// for a bare line cloud, line anchors): `up` from the keyframes' camera up axes (-y), else the
// content's direction of least spread; horizontal axes along its principal directions. The box
// (robust 0.5-99.5 % extents, padded 5 %) is expressed in this frame.
struct MapFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // world, map units
  Eigen::Matrix3d world_from_frame = Eigen::Matrix3d::Identity();  // columns: axis1, axis2, up
  Eigen::Vector3d box_min = -Eigen::Vector3d::Ones();  // frame coordinates
  Eigen::Vector3d box_max = Eigen::Vector3d::Ones();

  Eigen::Vector3d ToFrame(const Eigen::Vector3d& p_in_world) const {
    return world_from_frame.transpose() * (p_in_world - origin);
  }
  Eigen::Vector3d ToWorld(const Eigen::Vector3d& p_in_frame) const {
    return world_from_frame * p_in_frame + origin;
  }
  double Diagonal() const { return (box_max - box_min).norm(); }
};

MapFrame ComputeMapFrame(const slam::Map& map);

// The part of a line inside the frame's box, as world end points; empty when it misses the box.
std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> ClipLineToBox(const slam::Line3d& line,
                                                                        const MapFrame& frame);

enum class SnapshotView { kTop, kOblique, kKeyframe, kExplicit };
enum class SnapshotColorBy { kSource, kRisk };

struct SnapshotOptions {
  int cols = 1280;  // px
  int rows = 720;
  SnapshotView view = SnapshotView::kOblique;
  double azimuth_deg = 225.0;   // kOblique: around up, from axis1
  double elevation_deg = 35.0;  // kOblique: above the horizontal plane
  slam::Id keyframe_id = slam::kInvalidId;  // kKeyframe: a client or server keyframe
  // kExplicit: the viewing camera (intrinsics scaled to cols x rows; non-perspective models are
  // drawn as a 90-degree pinhole) and its pose.
  std::optional<slam::CameraParams> camera;
  slam::Rigid3d cam_from_world;
  SnapshotColorBy color_by = SnapshotColorBy::kSource;
  std::map<slam::Id, double> line_risk;  // kRisk: risk in [0, 1] per line id; others grey
  std::vector<std::pair<slam::Id, slam::Id>> loop_edges;  // keyframe id pairs to highlight
  bool legend = false;
};

// How world points map to snapshot pixels (for tests and overlays).
struct SnapshotCamera {
  int cols = 0, rows = 0;
  bool orthographic = false;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // orthographic: fx = fy = px per map unit
  slam::Rigid3d cam_from_world;
  double near = 0.01, far = 1e6;  // map units along the viewing axis
  // Pixel of a world point; empty behind a perspective camera (not clipped to the image).
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_in_world) const;
};

struct Snapshot {
  cv::Mat image;  // CV_8UC3 BGR, cols x rows
  SnapshotCamera camera;
};

class MapSnapshotRenderer {
 public:
  MapSnapshotRenderer();
  ~MapSnapshotRenderer();
  MapSnapshotRenderer(const MapSnapshotRenderer&) = delete;
  MapSnapshotRenderer& operator=(const MapSnapshotRenderer&) = delete;

  // Precondition (checked, std::logic_error): cols, rows in [16, 8192]; kKeyframe names an
  // existing keyframe; kExplicit has a camera without Problem(). Apps validate user input first.
  Snapshot Render(const slam::Map& map, const SnapshotOptions& options);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One-shot convenience: RenderMapSnapshot(map, options).image.
Snapshot RenderMapSnapshot(const slam::Map& map, const SnapshotOptions& options = {});

// Writes image as PNG atomically (fixed encoder settings: identical input, identical bytes).
// Throws lcv::InputError naming the path when it cannot be written.
void WritePng(const cv::Mat& image, const std::string& path);

}  // namespace lcv::render
