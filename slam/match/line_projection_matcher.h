#pragma once
// 2D point - 3D line matching by projection of discretized lines (paper Sec. 3.3), the line
// cloud's twin of MatchByProjection (slam/match/projection_matcher.h).
//
// A published line L = {anchor, direction} hides a 3D point X_L somewhere on it (mapping/
// line_cloud.h: the direction is random and the anchor is the point of the line closest to the
// map origin, so neither says where X_L is). The client can only search where X_L may be: the
// parameter interval [s_min, s_max] along the line over which X_L was visible to every server
// keyframe that saw it (LineVisibleInterval below). The matcher discretizes that stretch of the
// line into 3D sample points, projects them with the frame's camera model and gathers keypoints
// near each projection from a grid index (a finer copy of the frame's KeypointGrid holding only
// the free keypoints, see search_cell_px). Working on 3D samples instead of a 2D line
// segment is what lets perspective (with distortion), fisheye and equirectangular cameras run
// through the same code: the image of a 3D line is a curve under all three models.
//
// Discretization (chosen and measured in slam/match/README.md, bench/bench_line_matching.cc).
// The line's points seen from the camera centre sweep an arc of a great circle: with f the foot
// of the perpendicular from the centre to the line and h = |f|, the point at bearing angle phi
// (measured in the plane of the line and the centre, from f) is s = s_f + h tan(phi). Samples
// are stepped in phi, each step sized from the camera model's Jacobian at the current sample
// (pixels per radian of bearing along the line there) so that consecutive samples project
// step_px apart. Stepping in phi rather than in s removes the 1/depth^2 change of the pixel
// speed along the line, leaving only the lens's slow change of magnification, so the first-order
// step holds without a corrector. The phi range is cut analytically to the cone holding the
// image (its corners' angle from the axis, at most Camera::MaxViewAngle) and to distances
// >= min_depth before any projection; off the image the walk jumps by the pixel distance to it.
// Before a sample is projected it passes the point matcher's viewing test (below, cheap: no
// trigonometry): a 360-degree camera images every line over its whole interval, most of it from
// directions the server keyframes never looked from, where ORB would not find the hidden point.
// Samples are projected as unit bearings: the camera models are central (a point and its bearing
// image at the same pixel), as all of slam/camera's are.
//
// Thread safety: the function reads the candidates and writes only *frame, *scratch and
// *matches_out; one scratch per thread (its helper threads are the scratch's own).

#include <limits>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "slam/camera/camera.h"
#include "slam/data/frame.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/match/free_keypoint_cells.h"
#include "slam/util/ids.h"
#include "slam/util/parallel_for.h"

namespace lcv::slam {

// A line of the line cloud that tracking may match, with the parameter interval [s_min, s_max]
// along line.direction (from line.anchor, map units) where its hidden point can lie
// (LineVisibleInterval). s_min > s_max: the line is skipped.
struct LineMatchCandidate {
  Id line_id = kInvalidId;
  Line3d line;  // world frame, unit direction
  double s_min = 0.0, s_max = 0.0;
  OrbDescriptor descriptor{};
  // Centroid (world frame, map units) of the centres of the server keyframes that saw the hidden
  // point (SlamLine::server_keyframe_ids), for the viewing test of LineMatchOptions;
  // has_viewers false: the line's samples are not tested.
  bool has_viewers = false;
  Eigen::Vector3d viewers_centroid = Eigen::Vector3d::Zero();
};

struct LineMatchOptions {
  // Target distance (px) between the projections of consecutive samples. With square windows of
  // half-size radius_px, a keypoint off the projected curve by e px is found for sure when
  // e <= sqrt(2) radius_px - step_px / 2 (the worst case, a curve running diagonally; e <=
  // radius_px for an axis-aligned one), hence step_px <= 2 radius_px. 12 px with radius 8 px
  // (e >= 5.3 px): recall within 0.2% of the finest step measured (4 px) at ~40% of its time
  // (slam/match/README.md).
  double step_px = 12.0;
  // Cap on the samples of one line (a long line seen close up). When the line's predicted sample
  // count (its angular extent inside the image's cone over the camera's radians per pixel at the
  // image centre) exceeds the cap, its step grows for that line only (past 2 radius_px its
  // windows leave gaps); the walk also stops at the cap (projected samples: those failing the
  // viewing test below are not counted).
  int max_samples_per_line = 200;
  // Half-size (px) of the square search window around each sample's projection, the same for all
  // octaves: the hidden point's distance, hence its octave, is unknown. It must cover the
  // prediction error (pose error, keypoint noise) plus the discretization gap above. 8 px:
  // recall >= 99.7% at a pose 2 cm / 0.2 degrees off (README); callers searching from a rougher
  // prediction (motion model right after a loss) should pass a larger radius.
  float radius_px = 8.f;
  // A match needs Hamming distance <= max_hamming_distance and best < ratio * second best of
  // the line (1 disables), unless the second best is the same corner at another octave (within
  // 2 px x its scale). A line's corridor holds ~10x the keypoints of a point's window, so the
  // point matcher's bar (ORB-SLAM's TH_HIGH = 100) lets look-alike clutter through: measured
  // precision 96-98% at 100 and 80, >= 99.9% at 64 with the same recall (README). True ORB
  // matches beyond 64 bits are lost; ratio 0.8 is ORB-SLAM's usual value.
  int max_hamming_distance = 64;
  float ratio = 0.8f;
  // Samples closer than min_depth to the camera centre (map units) are skipped: at the centre
  // the projection of the line degenerates, and ORB keypoints are not seen that close.
  double min_depth = 0.05;
  double image_margin_px = 0.0;  // samples projecting closer to the border are skipped
  // Viewing test of each sample X(s) of a line with viewers, before it is projected: the rules
  // under which the point matcher searches a map point (Tracker::MatchLocalMap, ORB-SLAM's
  // isInFrustum), applied to X(s) as if the hidden point were there:
  // - view angle: the frame's ray to X(s) within max_view_angle_deg of the viewers' ray to X(s)
  //   (from their centroid; the point matcher's 60 degrees against the mean viewing direction);
  // - scale: the frame's distance to X(s) within [0.8 d / S, 1.2 d S], d the viewers' distance
  //   to X(s) and S = scale_factor^(num_levels - 1) the frame's pyramid span (the octave of the
  //   server's observation is not published, so any pair of octaves is allowed; 0.8 and 1.2 are
  //   the point matcher's slack).
  // A failing sample costs no projection and no window; the walk moves on by the nominal step.
  // Measured on the overlap pairs (docs/benchmarks-lcvslam.md): equirectangular clients skip
  // 20-60% of their samples; perspective ~4% (scale only: its cone already keeps the view).
  // max_view_angle_deg >= 180 switches the angle part off; check_scale_range the other.
  double max_view_angle_deg = 60.0;
  bool check_scale_range = true;
  // Cell size (px) of the search grid of free keypoints built in the scratch once per call
  // (O(keypoints)): a window of 2 radius_px scans every keypoint of the cells it touches, and
  // the frame's KeypointGrid (32 px cells, all keypoints, indices into the keypoint array) scans
  // ~10x the window's area; 0 searches the frame's grid instead. Measured in the README.
  int search_cell_px = 8;
  // Threads of the per-line search (the caller and num_threads - 1 helpers of the scratch's
  // pool; slam/util/parallel_for.h). Each line's best keypoints are found independently and
  // combined afterwards in line order, so the matches do not depend on it. 1: the caller only.
  // Without the grid (search_cell_px 0) the search runs on the caller. Measured in
  // docs/benchmarks-lcvslam.md ("Line search on two threads").
  int num_threads = 2;
};

// One match: the keypoint, the line, and where on the line the keypoint's ray passes.
struct LineMatch {
  int keypoint_index = -1;
  Id line_id = kInvalidId;
  // Parameter of the point of the line closest to the keypoint's bearing ray (a first estimate
  // of the hidden point for a restored point X'), clamped into [s_min, s_max]; sample_s when the
  // ray is parallel to the line or the closest point is behind the camera.
  double s = 0.0;
  double sample_s = 0.0;  // parameter of the sample whose search window found the keypoint
};

// The best and second-best keypoints of one line over all its samples (LineMatchScratch).
struct LineBest {
  int best = std::numeric_limits<int>::max();
  int second = std::numeric_limits<int>::max();
  int best_index = -1;
  int second_index = -1;
  int best_octave = -1;
  int second_octave = -1;
  double best_sample_s = 0.0;  // the sample's line parameter (its phi while walking)
  int num_windows = 0;  // samples inside the image whose windows were searched
};

// What one worker of the line search writes (the caller is worker 0; see
// LineMatchOptions::num_threads): visited stamps of the search grid's slots (per slot: last
// candidate index that scored it) and its share of the call's statistics. Each on its own cache
// line: the workers sit side by side in LineMatchScratch::workers and bump their counters for
// every sample, which would otherwise bounce one line between the cores.
struct alignas(64) LineSearchWorker {
  std::vector<int> visited_slots;
  int num_projections = 0;
  int num_samples = 0;
  int num_window_hits = 0;
  int num_culled = 0;
};

// Reusable per-call buffers (STYLE.md 8): keep one per tracking thread. No allocation per frame
// once grown.
struct LineMatchScratch {
  FreeKeypointCells free_cells;  // search grid of the free keypoints (search_cell_px > 0)
  std::vector<int> window;       // frame grid query result (search_cell_px 0)
  std::vector<int> visited_by_line;  // per keypoint: last candidate index that scored it
  std::vector<int> best_distance_per_keypoint;
  std::vector<int> line_per_keypoint;  // winning candidate index, -1 when none
  std::vector<double> sample_s_per_keypoint;
  std::vector<LineBest> best_per_line;            // per candidate, written by the workers
  std::vector<LineSearchWorker> workers;
  std::unique_ptr<ParallelFor> pool;              // helpers, started on the first parallel call
  // Statistics of the last call, for benchmarks and tests.
  int num_projections = 0;  // samples projected
  int num_samples = 0;      // samples inside the image, whose windows were searched
  int num_window_hits = 0;  // keypoints scored (Hamming distances computed)
  int num_culled = 0;       // samples failing the viewing test (not projected)
};

// Matches free keypoints of the frame (landmark_ids[i] == kInvalidId; a keypoint holding a
// landmark or line, outlier or not, is never touched) to the lines seen from cam_from_world
// (map units, the frame's camera). Each line keeps its best keypoint over all its samples
// (each keypoint scored once per line) if it passes max_hamming_distance and the ratio test
// against the line's second-best keypoint; each keypoint then goes to the line with the closest
// descriptor (many-to-many resolved to one-to-one). Writes frame->landmark_ids[i] = line_id and
// clears frame->is_outlier[i] for the matches; returns their number. If matches_out is
// non-null, appends one LineMatch per match (in keypoint order).
// An image that wraps horizontally (equirectangular, detected through Camera::Unproject) is
// searched across its seam: a window near one side edge continues on the other.
// Requires a prepared frame (PrepareFrame). Never throws per frame.
int MatchLinesByProjection(const std::vector<LineMatchCandidate>& lines,
                           const Rigid3d& cam_from_world, const LineMatchOptions& options,
                           Frame* frame, LineMatchScratch* scratch,
                           std::vector<LineMatch>* matches_out = nullptr);

// Where the hidden point of a line can lie: the interval of the line parameter s (map units
// along line.direction from line.anchor) over which the point is in front of and inside the
// image of every server keyframe that sees the line (server_cam_from_world[k] imaged by
// *cameras[k]), and at a distance in [min_distance, max_distance] from each keyframe's centre.
// Each keyframe's visible set is found by sampling the line uniformly in bearing angle (0.5
// degree) through Camera::Project and InImage and bisecting each change of visibility to 1e-9
// of the interval's length, so every camera model works; visible stretches narrower than the
// sampling are missed. The sets are intersected; the result is the hull of the intersection
// (conservative when it has several pieces, e.g. a fisheye beyond 180 degrees). Empty optional
// when the intersection is empty, when no keyframe is given, or when a distance bound makes it
// so. Preconditions: equal sizes, non-null cameras, 0 <= min_distance < max_distance < inf
// (checked, std::logic_error). Cost: up to ~600 projections per keyframe: meant for loading
// or publishing a line cloud, not per frame.
std::optional<std::pair<double, double>> LineVisibleInterval(
    const Line3d& line, const std::vector<Rigid3d>& server_cam_from_world,
    const std::vector<const Camera*>& cameras, double min_distance, double max_distance);

}  // namespace lcv::slam
