#pragma once
// The SLAM engine behind one facade: monocular tracking (constant-velocity prediction,
// projection matching, motion-only BA, local-map tracking, keyframe decision) and local mapping
// (keyframe insertion, point culling, triangulation, local BA, keyframe culling).
//
// Threads (STYLE.md 5; docs/slam.md "Threads"): TrackImage runs tracking on the caller's
// thread and never touches the map: it reads the latest immutable LocalMapSnapshot and hands
// keyframes, initialization, relocalization and resets to the mapping thread, the map's only
// writer, which republishes a snapshot after each change. Loop closing runs on a third thread on
// copies of the map and hands its corrections and global BA results back to the writer.
// Offline (options.live false) the caller waits when mapping is behind (a full keyframe queue,
// the initial map, a relocalization); live (options.live) it never waits: keyframes are refused
// and answers are taken on a later frame. In deterministic mode (options.deterministic) there
// are no threads: each stage runs inline in the same order, so a run is reproducible bit for
// bit.
//
// Inputs are images; the engine reads no files (apps wire mapping/io to it).
// Thread safety: one thread calls TrackImage/Finish; the accessors may be called from that
// thread after Finish().

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "slam/camera/camera.h"
#include "slam/data/map.h"
#include "slam/feature/keypoint.h"
#include "slam/frame_result.h"
#include "slam/geometry/rigid3.h"
#include "slam/system_options.h"
#include "slam/system_stats.h"
#include "slam/util/ids.h"

namespace cv {
class Mat;
}

namespace lcv::slam {

struct TimedPose {
  Id id = kInvalidId;
  double timestamp = 0.0;
  Rigid3d cam_from_world;
};

class System {
 public:
  // camera: the camera of every image. Precondition: !camera.Problem().
  System(const CameraParams& camera, const SystemOptions& options);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  // Before the first frame: starts from a saved map (keyframes with keypoints and descriptors,
  // points with observations) instead of initializing; the first frames relocalize in it.
  // Without options.localization_only the map is extended. Throws std::invalid_argument naming
  // the problem when the map cannot be used (no keyframes, keyframes without descriptors, a
  // camera unlike this system's, a line cloud alone with options.localization_only).
  void LoadMap(const Map& map);

  // Tracks one image (8-bit gray or BGR, camera size), timestamp in seconds, increasing. mask:
  // empty or 8-bit, non-zero where features may be detected.
  FrameResult TrackImage(const cv::Mat& image, double timestamp);
  FrameResult TrackImage(const cv::Mat& image, const cv::Mat& mask, double timestamp);

  // Tracks pre-extracted features (keypoints in raw image pixels with octave and angle, one
  // descriptor each), bypassing the ORB extractor: for synthetic tests and external front ends.
  FrameResult TrackFeatures(std::vector<Keypoint> keypoints, std::vector<OrbDescriptor> descriptors,
                            double timestamp);

  // Drains the keyframe queue and stops the mapping thread. Further TrackImage calls are
  // invalid.
  void Finish();

  // After Finish(): every tracked frame's pose, re-anchored to its reference keyframe's final
  // pose (so it reflects local BA), in frame order.
  std::vector<TimedPose> FrameTrajectory() const;
  // After Finish(): keyframe poses, by id.
  std::vector<TimedPose> KeyframeTrajectory() const;
  // After Finish(): the map as the persistent model (one camera, id 0).
  Map ExportMap() const;
  // After Finish(): the kept maps (segments) that the outputs above leave out, lost for good and
  // never merged (SlamMap::OutputSegment; SystemStats::maps_left_out), each in its own frame and
  // scale (docs/slam.md "Which segment the outputs hold"). The two below give a map's tracked
  // frames' poses and its map file, for `map` one of LeftOutMaps() or TrajectoryMap().
  std::vector<int> LeftOutMaps() const;
  std::vector<TimedPose> FrameTrajectory(int map) const;
  Map ExportMap(int map) const;
  // After Finish(): the map the trajectory is in (for ExportMap(int)). ExportMap() writes the
  // loaded map instead when the run's own map never joined it (SystemStats::
  // trajectory_in_loaded_map_frame false): ExportMap(TrajectoryMap()) is the run's own then.
  int TrajectoryMap() const;
  int NumKeyframes() const;
  int NumLandmarks() const;
  // How many times the map was (re)initialized.
  int NumInitializations() const;
  // Counters so far (safe to call between TrackImage calls and after Finish).
  SystemStats Stats() const;

  const Camera& camera() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lcv::slam
