#pragma once
// Registration of a client keyframe's local map into a server line cloud (paper Sec. 3.2,
// "Relocalization and Loop Detection with a Line Cloud", and the rigid-stereo BA, Eq. 7), on
// plain data: the caller (relocalization, loop detection) copies the current client keyframe
// (ckf), its covisible keyframes, their 3D points X and the lines L of the candidate server
// keyframes in, and applies the returned similarity to its map.
//
// Steps:
// 1. Descriptor matching, brute force: every client point against every line (and every server
//    point), Hamming 2-NN, Lowe's ratio test and an absolute cap; when several client points
//    pick one line (server point), only the closest stays (one-to-one). Lines and server points
//    are matched separately: N_PL point-line and N_PP point-point matches.
// 2. Method (the paper's rule): P4L if N_PL / N_PP > 4/3 (also when N_PP = 0), else P3P (three
//    3D point-3D point pairs aligned by Umeyama). RANSAC (slam/solve/ransac.h) samples the
//    chosen kind only; the other kind is classified with the final model.
// 3. Scale-free inlier test: the client's scale is arbitrary, so the error is the server-side
//    distance of S * X to its line (or to its server point) divided by the distance of S * X
//    from the ckf's centre, s * |X - c_ckf| (an angle in radians, as seen from the ckf). A
//    threshold in server units would mean something else for every client map.
// 4. Refinement (RefineSim3PointLine, or Umeyama for P3P) on the inliers, then verification:
//    >= min_inliers inliers, >= min_inlier_ratio of all matches, scale within
//    [min_scale, max_scale], inlier points not collinear (min_spread_in_thresholds).
// 5. Rigid-stereo BA (slam/optimize/rigid_stereo_ba.h, Eq. 7): the ckf pose in the server frame
//    and the X' of the inlier point-line matches free, the other views rigid with the ckf (their
//    client poses relative to the ckf, translations times the RANSAC scale), every observation
//    of every inlier point in every view; inlier point-point matches join as fixed X' (their
//    server position). X' starts at InitialRestoredPoint (midpoint of the first observation's
//    ray and the line). Inlier points without observations stay out of the BA and the outputs.
// 6. server_from_client: the RANSAC scale with the rotation and translation that put the ckf
//    at its BA pose (TransformPose(server_from_client, views[0].cam_from_world) equals it).
//    The BA does not touch the scale (Eq. 7), so it carries the noise of the client's depths
//    into the fit (worst of 20 seeds in the bench: 0.6% at 1% depth noise, 3% at 3%), unless
//    refine_scale_in_ba frees the rigid group's scale in the BA.
//
// Frames and units: RegistrationView::cam_from_world and RegistrationPoint::position are in the
// client world frame and units; lines, server points, restored X' and the BA pose in the server
// world frame and units. Pixels as the cameras define them.
//
// Failure is a value: success false and `failure` saying which stage stopped ("12 point-line +
// 0 point-point matches < 20", "RANSAC (p4l): 9 inliers < 15"). Nothing throws for bad data;
// broken preconditions (observation view out of range, a view without a camera, invalid
// options) throw std::logic_error (LCV_CHECK).
//
// Thread safety: a pure function of its arguments; cameras are read only. Deterministic for a
// given options.random_seed. Cost: matching is O(points x (lines + server points)) Hamming
// distances (300 x 3000 ~ 9 ms); a registration of 300 points takes ~13 ms at 30% wrong
// matches and ~165 ms when it fails (max_ransac_trials P4L samples):
// bench/bench_line_registration.cc, numbers in slam/solve/README.md.

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/geometry/sim3.h"
#include "slam/optimize/bundle_adjustment.h"
#include "slam/util/ids.h"

namespace lcv::slam {

// A client keyframe. views[0] is the current keyframe (ckf), then its covisible keyframes.
struct RegistrationView {
  Id keyframe_id = kInvalidId;
  Rigid3d cam_from_world;          // client world frame
  const Camera* camera = nullptr;  // not owned, must outlive the call
};

// A keypoint of view `view` (index into the views) that observes the point.
struct RegistrationObservation {
  int view = -1;
  Eigen::Vector2d observed_px = Eigen::Vector2d::Zero();
  double information = 1.0;  // px^-2, 1 / sigma^2 of the keypoint's octave
};

// A client 3D point X of the ckf's local map.
struct RegistrationPoint {
  Id landmark_id = kInvalidId;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // client world frame
  OrbDescriptor descriptor{};
  std::vector<RegistrationObservation> observations;  // in the views
};

// A server line L of the candidate server keyframes (server world frame).
struct RegistrationLine {
  Id line_id = kInvalidId;
  Line3d line;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();  // Omega_L, server units^-2
  OrbDescriptor descriptor{};
};

// A server-side 3D point (an X' restored earlier, server frame). May be empty.
struct RegistrationServerPoint {
  Id id = kInvalidId;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  OrbDescriptor descriptor{};
};

struct LineCloudRegistrationOptions {
  // Descriptor matching (step 1), as LineCloudLocalizerOptions: best <= max_hamming_distance
  // bits (of 256) and best < ratio * second best.
  int max_hamming_distance = 64;
  double ratio = 0.8;
  // N_PL + N_PP below this: no RANSAC.
  int min_matches = 20;

  // RANSAC (step 3): inlier when distance / (s * |X - c_ckf|) <= max_relative_error. 0.03 is
  // 3% of the point's depth: a monocular point triangulated with a few degrees of parallax has
  // a depth error of that order (1 px at f = 500 over 4 degrees ~ 3%), while a line of another
  // scene point passes that close with a probability of about (0.03 depth / distance)^2 / 2.
  double max_relative_error = 0.03;
  int max_ransac_trials = 1000;  // P4L ~0.1 ms a sample: 1000 caps a failing attempt ~0.1 s
  double ransac_confidence = 0.999;
  std::uint64_t random_seed = 0;

  // Verification (step 4).
  int min_inliers = 15;           // point-line + point-point inliers
  double min_inlier_ratio = 0.2;  // of N_PL + N_PP
  // Server units per client unit. A monocular client's unit is about its first scene depth, so
  // the scale is the server's scene depth in its own unit: ~10 for a street in metres, ~1e4 in
  // millimetres, ~1e-2 in kilometres. A bound of 1e3 rejected a line cloud in centimetres
  // (scale ~1600: every attempt "degenerate scale"). The scale-free inlier test already rejects
  // the degenerate extremes (all points collapsed, or blown up, miss their lines by more than
  // max_relative_error of their range); this range only catches a numerically broken solve.
  double min_scale = 1e-6;
  double max_scale = 1e6;
  // Degenerate layout: the inlier client points' second principal standard deviation must
  // reach this many inlier thresholds at their median range (max_relative_error x median
  // range). Below it they are on a line up to noise, and the rotation about that line is left
  // to the noise (the cameras can turn about it unseen: it holds the points fixed).
  double min_spread_in_thresholds = 2.0;

  // A model to test before RANSAC (between steps 2 and 3): for a client already registered,
  // the identity, i.e. the map as it is. When as many matches agree with it (both kinds, at
  // max_relative_error) as step 4 asks of a RANSAC model (min_inliers, min_inlier_ratio), the
  // registration stops there: success false, prior_holds true, no RANSAC and no BA. The caller learns that the
  // map already agrees with the line cloud, which is all a loop check needs to know: a P4L
  // RANSAC that would find the identity again cost 11% of a registered equirectangular
  // client's run (docs/slam.md, "Loop closing in the line cloud").
  std::optional<Sim3d> prior;

  // Rigid-stereo BA (step 5). Afterwards a match is kept when at least one of its observations
  // is a BA inlier, and at least min_inliers matches must be kept.
  BundleOptions bundle;
  // Beyond Eq. 7: also optimize the scale of the rigid group (the views' baselines) in the BA,
  // from the pixels, instead of keeping the RANSAC scale, which noisy client depths bias low
  // (bench at 3% depth noise: 1.5-3% off with the RANSAC scale). Used only when views other
  // than the ckf observe inliers (else the scale is not observable).
  bool refine_scale_in_ba = true;

  // Empty when usable, else what is wrong ("ratio must be in (0, 1]").
  std::string Problem() const;
};

struct LineCloudRegistration {
  bool success = false;
  std::string failure;  // why not, when !success

  // Maps the whole client map into the server frame and units (after the rigid-stereo BA).
  Sim3d server_from_client;
  std::string method;               // "p4l" or "p3p" (empty when matching stopped it)
  int num_point_line_matches = 0;   // N_PL after ratio test and one-to-one
  int num_point_point_matches = 0;  // N_PP
  int num_inliers = 0;              // verified RANSAC inliers, both kinds
  int num_point_line_inliers = 0;
  int num_point_point_inliers = 0;
  int num_ransac_trials = 0;
  int num_ba_outlier_observations = 0;
  bool prior_holds = false;  // options.prior agreed with the matches (then num_*_inliers are its)

  struct RestoredPoint {
    Id landmark_id = kInvalidId;
    Id line_id = kInvalidId;
    Eigen::Vector3d position_in_server = Eigen::Vector3d::Zero();  // X' after the BA
  };
  std::vector<RestoredPoint> restored;           // inlier point-line matches kept by the BA
  std::vector<std::pair<Id, Id>> point_matches;  // inlier (landmark, server point), kept by BA
};

// See the header comment. Precondition: !views.empty(), every view has a camera, every
// observation's view is in range, options.Problem() empty (LCV_CHECK).
LineCloudRegistration RegisterToLineCloud(const std::vector<RegistrationView>& views,
                                          const std::vector<RegistrationPoint>& points,
                                          const std::vector<RegistrationLine>& lines,
                                          const std::vector<RegistrationServerPoint>& server_points,
                                          const LineCloudRegistrationOptions& options);

}  // namespace lcv::slam
