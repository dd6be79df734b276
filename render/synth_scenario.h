#pragma once
// The synthetic scenarios of `lcv synth`, mirroring the paper's CARLA protocol (Sec. 4): each is a
// textured Scene plus a *pair* of camera paths, the map sequence and the client sequence, with a
// known overlap.
//
//   tracking  a straight street lined with buildings; the client drives almost the same path as
//             the map sequence (small lateral, height and heading offsets).
//   overlap   the same street; the map sequence covers its first ~60 %, the client its last ~60 %.
//   loop      a city block with streets all around; the map sequence covers about half of the
//             ring, the client starts inside it, leaves the mapped part, drives around the block
//             and re-enters it (loop closure).
//   desk      an indoor room with a desk and objects on it, the camera orbiting the desk; the
//             privacy object (a document standing on the desk) is in the map sequence only.
//
// World frame: metres, z up. Poses are cam_from_world (camera x right, y down, z forward).
// Everything is a function of (name, frames, seed): same arguments, identical scene and poses.

#include <cstdint>
#include <string>
#include <vector>

#include "render/scene.h"
#include "slam/camera/camera.h"
#include "slam/geometry/rigid3.h"

namespace lcv::render {

struct Scenario {
  std::string name;
  std::uint64_t seed = 0;
  Scene scene;
  std::vector<slam::Rigid3d> map_cam_from_world;     // one per map frame
  std::vector<slam::Rigid3d> client_cam_from_world;  // one per client frame
  double fps = 10.0;                                 // frame rate of both sequences, Hz
};

// "tracking", "overlap", "loop", "desk".
const std::vector<std::string>& ScenarioNames();

// Precondition: name is one of ScenarioNames() and frames >= 1 (checked, std::logic_error).
// Both sequences get `frames` frames.
Scenario MakeScenario(const std::string& name, int frames, std::uint64_t seed);

// The camera the synthetic sequences use for a model at a size (cols x rows px):
// perspective 80 degrees horizontal field of view, no distortion; fisheye (Kannala-Brandt, mild
// k1..k3) 190 degrees across the width; equirectangular the full sphere. Principal point at the
// image centre ((cols - 1) / 2, (rows - 1) / 2).
slam::CameraParams SynthCamera(slam::CameraModel model, int cols, int rows, double fps = 10.0);

}  // namespace lcv::render
