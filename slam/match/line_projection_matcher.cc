#include "slam/match/line_projection_matcher.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>

#include "slam/camera/equirectangular.h"
#include "slam/match/epipolar_matcher.h"
#include "slam/util/error.h"
#include "slam/util/parallel_for.h"

namespace lcv::slam {
namespace {

// A set of at most kMaxPieces disjoint intervals of the bearing angle phi, without allocation.
struct PhiSet {
  static constexpr int kMaxPieces = 4;
  std::array<std::pair<double, double>, kMaxPieces> pieces;
  int count = 0;

  void Add(double lo, double hi) {
    if (lo < hi && count < kMaxPieces) pieces[count++] = {lo, hi};
  }
  // Keeps the parts inside [lo, hi].
  void Intersect(double lo, double hi) {
    int kept = 0;
    for (int i = 0; i < count; ++i) {
      const double a = std::max(pieces[i].first, lo), b = std::min(pieces[i].second, hi);
      if (a < b) pieces[kept++] = {a, b};
    }
    count = kept;
  }
  // Removes (lo, hi).
  void Subtract(double lo, double hi) {
    PhiSet out;
    for (int i = 0; i < count; ++i) {
      out.Add(pieces[i].first, std::min(pieces[i].second, lo));
      out.Add(std::max(pieces[i].first, hi), pieces[i].second);
    }
    *this = out;
  }
  double Extent() const {
    double sum = 0.0;
    for (int i = 0; i < count; ++i) sum += pieces[i].second - pieces[i].first;
    return sum;
  }
};

// The phi range of s in [s_min, s_max] on a line at distance h from the camera centre, cut to
// the view cone (angle to +z <= max_view_angle) and to distances >= min_depth.
// p(phi) = foot + h tan(phi) dir; its bearing is cos(phi) foot/h + sin(phi) dir.
PhiSet VisiblePhiRange(const Eigen::Vector3d& foot, const Eigen::Vector3d& dir, double h,
                       double s_foot, double s_min, double s_max, double max_view_angle,
                       double min_depth) {
  PhiSet set;
  const double phi_lo = std::atan((s_min - s_foot) / h);
  const double phi_hi = std::atan((s_max - s_foot) / h);
  // Cone: bearing.z = A cos(phi - psi) >= cos(max_view_angle).
  const double k = std::cos(max_view_angle);
  const double a_cos = foot.z() / h, a_sin = dir.z();
  const double amplitude = std::hypot(a_cos, a_sin);
  if (k <= -amplitude) {
    set.Add(phi_lo, phi_hi);
  } else if (k < amplitude) {
    const double psi = std::atan2(a_sin, a_cos);
    const double half_width = std::acos(k / amplitude);
    // The cone's phi set repeats every 2 pi; [phi_lo, phi_hi] lies in (-pi/2, pi/2).
    for (int n = -1; n <= 1; ++n) {
      const double center = psi + 2.0 * M_PI * n;
      set.Add(std::max(phi_lo, center - half_width), std::min(phi_hi, center + half_width));
    }
  }
  if (h < min_depth) {
    const double alpha = std::acos(h / min_depth);
    set.Subtract(-alpha, alpha);
  }
  return set;
}

// The angle from the optical axis within which the image lies: the largest angle of the image's
// corners and edge midpoints (radial models grow monotonically with the distance from the
// principal point, so the corners bound it), capped by MaxViewAngle; MaxViewAngle itself when a
// border pixel does not unproject (a fisheye's corners outside its image circle). Cutting the
// lines to this cone spares projections and keeps the sample cap's prediction honest.
double ImageConeAngle(const Camera& camera) {
  const double max_view_angle = std::min(camera.MaxViewAngle(), M_PI);
  const double right = camera.cols() - 1.0, bottom = camera.rows() - 1.0;
  double angle = 0.0;
  for (const double u : {0.0, 0.5 * right, right}) {
    for (const double v : {0.0, 0.5 * bottom, bottom}) {
      if (u != 0.0 && u != right && v != 0.0 && v != bottom) continue;  // the centre
      const std::optional<Eigen::Vector3d> bearing = camera.Unproject(Eigen::Vector2d(u, v));
      if (!bearing) return max_view_angle;
      angle = std::max(angle, std::acos(std::clamp(bearing->normalized().z(), -1.0, 1.0)));
    }
  }
  return std::min(max_view_angle, angle + 1e-3);
}

// Whether the image wraps horizontally (a 360-degree panorama): columns one image width apart
// see the same bearing. Checked through Unproject, so no code here switches on the model.
bool WrapsHorizontally(const Camera& camera) {
  const double y = 0.5 * (camera.rows() - 1);
  const std::optional<Eigen::Vector3d> a = camera.Unproject(Eigen::Vector2d(0.25, y));
  const std::optional<Eigen::Vector3d> b =
      camera.Unproject(Eigen::Vector2d(0.25 + camera.cols(), y));
  return a && b && (a->normalized() - b->normalized()).norm() < 1e-9;
}

// The viewing test of LineMatchOptions for the sample of unit `bearing` (camera frame) on a line
// at distance h from the centre, cos_phi = bearing . foot_dir > 0, the viewers' centroid at
// viewers_in_cam. The sample is at depth h / cos_phi; the test is homogeneous in scale, so it
// runs on everything multiplied by cos_phi: no division, no square root (most samples of a
// 360-degree camera fail it, and then this is all they cost).
inline bool ViewableFrom(const Eigen::Vector3d& bearing, double h, double cos_phi,
                         const Eigen::Vector3d& viewers_in_cam, bool test_view_angle,
                         double cos_max_view, bool check_scale_range, double min_ratio2,
                         double max_ratio2) {
  const Eigen::Vector3d from_viewers = h * bearing - cos_phi * viewers_in_cam;
  const double viewers_distance2 = from_viewers.squaredNorm();
  if (check_scale_range) {
    const double depth2 = h * h;
    if (depth2 < min_ratio2 * viewers_distance2 || depth2 > max_ratio2 * viewers_distance2) {
      return false;
    }
  }
  if (!test_view_angle) return true;
  // cos of the angle between the frame's ray and the viewers' ray = along / |from_viewers|
  // >= cos_max_view, squared with the signs kept apart.
  const double along = bearing.dot(from_viewers);
  const double bound2 = cos_max_view * cos_max_view * viewers_distance2;
  return cos_max_view >= 0.0 ? along >= 0.0 && along * along >= bound2
                             : along >= 0.0 || along * along <= bound2;
}

// sin and cos of a walk step (rad) by their series up to 0.1 (error < 2e-9), longer series up to
// 0.25 (error < 1e-12), libm beyond (rare: steps are at most 1.5 nominal steps). The bearing is
// re-derived per line, so the rotation's drift stays within a line's ~30 steps.
inline void SinCosOfStep(double step, double* sin_step, double* cos_step) {
  const double step2 = step * step;
  if (step <= 0.1) {
    *sin_step = step * (1.0 - step2 / 6.0 * (1.0 - step2 / 20.0));
    *cos_step = 1.0 - step2 / 2.0 * (1.0 - step2 / 12.0);
  } else if (step <= 0.25) {
    *sin_step =
        step * (1.0 - step2 / 6.0 * (1.0 - step2 / 20.0 * (1.0 - step2 / 42.0 *
                                                                  (1.0 - step2 / 72.0))));
    *cos_step =
        1.0 - step2 / 2.0 * (1.0 - step2 / 12.0 * (1.0 - step2 / 30.0 * (1.0 - step2 / 56.0)));
  } else {
    *sin_step = std::sin(step);
    *cos_step = std::cos(step);
  }
}

// Scores the free keypoints near px (each once per line) against the line's descriptor.
inline void ScoreWindow(const Eigen::Vector2d& px, double sample_key, int line_index,
                        const OrbDescriptor& descriptor, float radius_px,
                        const FreeKeypointCells* grid,
                        Frame* frame, LineMatchScratch* scratch, LineSearchWorker* worker,
                        LineBest* best) {
  ++worker->num_samples;
  ++best->num_windows;
  const auto offer = [&](int i, int d, int octave) {
    ++worker->num_window_hits;
    if (d < best->best) {
      best->second = best->best;
      best->second_octave = best->best_octave;
      best->second_index = best->best_index;
      best->best = d;
      best->best_index = i;
      best->best_octave = octave;
      best->best_sample_s = sample_key;
    } else if (d < best->second) {
      best->second = d;
      best->second_octave = octave;
      best->second_index = i;
    }
  };
  const float x = static_cast<float>(px.x()), y = static_cast<float>(px.y());
  if (grid != nullptr) {
    // The grid holds free keypoints only.
    grid->ForEachInWindow(x, y, radius_px, [&](int k) {
      int& visited = worker->visited_slots[k];
      if (visited == line_index) return;
      visited = line_index;
      offer(grid->keypoint[k], HammingDistance(descriptor, grid->descriptor[k]), grid->octave[k]);
    });
  } else {
    // Without the grid the search runs on one thread (worker 0), with the scratch's buffers.
    frame->grid.Query(frame->keypoints, x, y, radius_px, 0, -1, &scratch->window);
    for (const int i : scratch->window) {
      if (scratch->visited_by_line[i] == line_index) continue;
      scratch->visited_by_line[i] = line_index;
      if (frame->landmark_ids[i] != kInvalidId) continue;
      offer(i, HammingDistance(descriptor, frame->descriptors[i]), frame->keypoints[i].octave);
    }
  }
}

// Whether the second-best keypoint of a line is the best one's corner detected again at another
// pyramid level (same place within 2 px at the coarser level's scale): such twins look alike
// legitimately and must not fail the ratio test. MatchByProjection skips the ratio test for
// any second best of another octave; along a line's corridor, where many keypoints compete,
// that would switch the test off for most lines, hence the position condition.
bool SameCornerAtOtherOctave(const Frame& frame, const LineBest& best) {
  if (best.second_index < 0 || best.second_octave == best.best_octave) return false;
  const Keypoint& a = frame.keypoints[best.best_index];
  const Keypoint& b = frame.keypoints[best.second_index];
  const double same_place_px =
      2.0 * frame.scale_levels.Scale(std::max(best.best_octave, best.second_octave));
  return std::abs(a.x - b.x) <= same_place_px && std::abs(a.y - b.y) <= same_place_px;
}

}  // namespace

int MatchLinesByProjection(const std::vector<LineMatchCandidate>& lines,
                           const Rigid3d& cam_from_world, const LineMatchOptions& options,
                           Frame* frame, LineMatchScratch* scratch,
                           std::vector<LineMatch>* matches_out) {
  const Camera& camera = *frame->camera;
  const int num_keypoints = frame->num_keypoints();
  scratch->best_distance_per_keypoint.assign(num_keypoints, std::numeric_limits<int>::max());
  scratch->line_per_keypoint.assign(num_keypoints, -1);
  scratch->sample_s_per_keypoint.assign(num_keypoints, 0.0);
  scratch->num_samples = 0;
  scratch->num_projections = 0;
  scratch->num_window_hits = 0;
  scratch->num_culled = 0;
  if (num_keypoints == 0 || lines.empty()) return 0;
  const FreeKeypointCells* grid = nullptr;
  if (options.search_cell_px > 0) {
    scratch->free_cells.Build(*frame, options.search_cell_px,
                              [&](int i) { return frame->landmark_ids[i] == kInvalidId; });
    grid = &scratch->free_cells;
  }
  // The grid keeps its own visited stamps per slot; without it they are kept per keypoint.
  if (grid == nullptr) scratch->visited_by_line.assign(num_keypoints, -1);

  const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
  const Eigen::Vector3d& t = cam_from_world.translation;
  const double max_view_angle = ImageConeAngle(camera);
  const double radians_per_px = RadiansPerPixel(camera);
  const bool wraps = WrapsHorizontally(camera);
  // Panoramas project their samples with polynomial atan2 (EquirectangularCamera::ProjectApprox).
  const auto* equirectangular = camera.model() == CameraModel::kEquirectangular
                                    ? static_cast<const EquirectangularCamera*>(&camera)
                                    : nullptr;
  const double cols = camera.cols(), rows = camera.rows();
  const double margin = options.image_margin_px;
  const double min_depth = std::max(options.min_depth, 0.0);
  const int max_samples = std::max(options.max_samples_per_line, 1);
  // Angular steps are kept within [kMinStep, max_step] rad whatever the Jacobian says (a line
  // seen end-on projects to almost one pixel; a degenerate Jacobian must not stall the walk).
  // max_step is 0.1 rad, or 1.5 nominal steps where that is more: a fixed 0.1 bound cut the
  // equirectangular step (0.118 rad = 12 px at 640 columns) to 10.2 px, 17% more samples than
  // chosen; perspective and fisheye steps (<= 0.06 rad at 640x360) keep the 0.1 bound.
  const double kMinStep = 1e-6;
  const double kSeriesStep = 0.1;  // see SinCosOfStep
  // Viewing test (LineMatchOptions::max_view_angle_deg, check_scale_range).
  const double max_view_angle_rad = options.max_view_angle_deg * M_PI / 180.0;
  const bool test_view_angle = max_view_angle_rad < M_PI;
  const double cos_max_view = std::cos(max_view_angle_rad);
  const double pyramid_span =
      frame->scale_levels.Scale(frame->scale_levels.num_levels() - 1);  // S
  const double min_distance_ratio = 0.8 / pyramid_span, max_distance_ratio = 1.2 * pyramid_span;
  const double min_ratio2 = min_distance_ratio * min_distance_ratio;
  const double max_ratio2 = max_distance_ratio * max_distance_ratio;

  // Phase 1, per line (independent of the other lines, so it runs on the workers): the line's
  // best and second-best keypoints over all its samples. Each worker keeps its own visited
  // stamps and counters; the result is written per line.
  const int num_lines = static_cast<int>(lines.size());
  const auto search_line = [&](int c, LineSearchWorker* worker, LineBest* out) {
    const LineMatchCandidate& candidate = lines[c];
    if (!(candidate.s_min <= candidate.s_max)) return;
    const Eigen::Vector3d anchor_in_cam = R * candidate.line.anchor + t;
    const Eigen::Vector3d dir = R * candidate.line.direction;
    assert(std::abs(dir.squaredNorm() - 1.0) < 1e-6);  // s is a distance along a unit direction
    const double s_foot = -anchor_in_cam.dot(dir);
    const Eigen::Vector3d foot = anchor_in_cam + s_foot * dir;
    const double h = foot.norm();
    LineBest best;

    if (!(h > 1e-9 * (1.0 + anchor_in_cam.norm()))) {
      // The line passes through the camera centre: each side images to one pixel.
      for (const double side : {-1.0, 1.0}) {
        const double lo =
            side > 0 ? std::max(candidate.s_min, s_foot + min_depth) : candidate.s_min;
        const double hi =
            side > 0 ? candidate.s_max : std::min(candidate.s_max, s_foot - min_depth);
        if (!(lo <= hi)) continue;
        const double s = 0.5 * (lo + hi);
        const std::optional<Eigen::Vector2d> px = camera.Project(side * dir);
        if (!px || !camera.InImage(*px, options.image_margin_px)) continue;
        ScoreWindow(*px, s, c, candidate.descriptor, options.radius_px, grid, frame, scratch,
                    worker, &best);
      }
    } else {
      const PhiSet range = VisiblePhiRange(foot, dir, h, s_foot, candidate.s_min, candidate.s_max,
                                           max_view_angle, min_depth);
      // A line longer (in the image) than max_samples steps gets a coarser step.
      double step_px = options.step_px;
      const double predicted = range.Extent() / (options.step_px * radians_per_px);
      if (predicted > max_samples) step_px *= predicted / max_samples;
      const Eigen::Vector3d foot_dir = foot / h;
      const double max_step = std::max(kSeriesStep, 1.5 * step_px * radians_per_px);
      const double nominal_step = std::clamp(step_px * radians_per_px, kMinStep, max_step);
      double nominal_sin, nominal_cos;
      SinCosOfStep(nominal_step, &nominal_sin, &nominal_cos);
      const bool test_viewers =
          candidate.has_viewers && (test_view_angle || options.check_scale_range);
      const Eigen::Vector3d viewers_in_cam = R * candidate.viewers_centroid + t;
      int samples = 0;
      for (int piece = 0; piece < range.count && samples < max_samples; ++piece) {
        const double phi_end = range.pieces[piece].second;
        double phi = range.pieces[piece].first;
        // The sample's bearing b = cos(phi) foot_dir + sin(phi) dir and its derivative
        // b_perp = db/dphi, rotated forward step by step (no trigonometry per sample). Central
        // models image a point and its bearing at the same pixel, so b is projected directly.
        Eigen::Vector3d bearing = std::cos(phi) * foot_dir + std::sin(phi) * dir;
        Eigen::Vector3d bearing_perp = -std::sin(phi) * foot_dir + std::cos(phi) * dir;
        while (samples < max_samples) {
          double step_rad = step_px * radians_per_px;
          const bool viewable =
              !test_viewers || ViewableFrom(bearing, h, bearing.dot(foot_dir), viewers_in_cam,
                                            test_view_angle, cos_max_view,
                                            options.check_scale_range, min_ratio2, max_ratio2);
          std::optional<Eigen::Vector2d> px;
          double px_per_rad = 0.0;
          if (viewable) {
            if (equirectangular) {
              px = equirectangular->ProjectApprox(bearing, bearing_perp, &px_per_rad);
            } else {
              Eigen::Matrix<double, 2, 3> J;
              px = camera.Project(bearing, &J);
              if (px) px_per_rad = (J * bearing_perp).norm();
            }
            ++samples;
            ++worker->num_projections;
          } else {
            ++worker->num_culled;
          }
          if (px) {
            // A panorama's columns wrap: x into [0, cols), and never off the image sideways.
            const double x = wraps ? px->x() - cols * std::floor(px->x() / cols) : px->x();
            const double y = px->y();
            // Off the image, no sample can find a keypoint before the curve has covered the
            // distance to the image (px_out): skip most of it at once.
            const double px_out = std::max(
                {wraps ? 0.0 : -x, wraps ? 0.0 : x - (cols - 1), -y, y - (rows - 1), 0.0});
            if (px_per_rad > 0.0) step_rad = std::max(step_px, 0.8 * px_out) / px_per_rad;
            const bool inside = wraps ? (y >= margin && y <= rows - 1 - margin)
                                      : camera.InImage(*px, margin);
            if (px_out == 0.0 && inside) {
              const Eigen::Vector2d at(x, y);
              ScoreWindow(at, phi, c, candidate.descriptor, options.radius_px, grid, frame,
                          scratch, worker, &best);
              // Near a panorama's seam the window continues on the other side.
              if (wraps && x < options.radius_px) {
                ScoreWindow(at + Eigen::Vector2d(cols, 0.0), phi, c, candidate.descriptor,
                            options.radius_px, grid, frame, scratch, worker, &best);
              } else if (wraps && x > cols - 1 - options.radius_px) {
                ScoreWindow(at - Eigen::Vector2d(cols, 0.0), phi, c, candidate.descriptor,
                            options.radius_px, grid, frame, scratch, worker, &best);
              }
            }
          }
          step_rad = std::clamp(step_rad, kMinStep, max_step);
          if (phi >= phi_end) break;
          // The last sample sits on the end of the range unless the previous one is close.
          if (phi + step_rad > phi_end && phi_end - phi < 0.3 * step_rad) break;
          step_rad = std::min(step_rad, phi_end - phi);
          phi += step_rad;
          double sin_step = nominal_sin, cos_step = nominal_cos;  // the step of skipped samples
          if (step_rad != nominal_step) SinCosOfStep(step_rad, &sin_step, &cos_step);
          const Eigen::Vector3d next = cos_step * bearing + sin_step * bearing_perp;
          bearing_perp = cos_step * bearing_perp - sin_step * bearing;
          bearing = next;
        }
      }
      best.best_sample_s = s_foot + h * std::tan(best.best_sample_s);  // phi -> s
    }
    *out = best;
  };

  const bool parallel = grid != nullptr && options.num_threads > 1;
  if (parallel && (!scratch->pool || scratch->pool->num_threads() != options.num_threads)) {
    scratch->pool = std::make_unique<ParallelFor>(options.num_threads);
  }
  const int num_workers = parallel ? options.num_threads : 1;
  scratch->best_per_line.assign(num_lines, LineBest());
  scratch->workers.resize(num_workers);
  for (LineSearchWorker& worker : scratch->workers) {
    if (grid != nullptr) worker.visited_slots.assign(grid->num_slots(), -1);
    worker.num_projections = worker.num_samples = worker.num_window_hits = worker.num_culled = 0;
  }
  const auto search_lines = [&](int begin, int end, int worker) {
    for (int c = begin; c < end; ++c) {
      search_line(c, &scratch->workers[worker], &scratch->best_per_line[c]);
    }
  };
  // Chunks of 8 lines: a line costs 0-200 samples, so the workers take work as they free up.
  if (parallel) {
    scratch->pool->Run(num_lines, 8, search_lines);
  } else {
    search_lines(0, num_lines, 0);
  }
  for (const LineSearchWorker& worker : scratch->workers) {
    scratch->num_projections += worker.num_projections;
    scratch->num_samples += worker.num_samples;
    scratch->num_window_hits += worker.num_window_hits;
    scratch->num_culled += worker.num_culled;
  }

  // Phase 2, in line order (the same result whatever the number of workers): the ratio test,
  // then each keypoint to the line with the closest descriptor.
  for (int c = 0; c < num_lines; ++c) {
    const LineBest& best = scratch->best_per_line[c];
    if (best.best_index < 0 || best.best > options.max_hamming_distance) continue;
    if (!SameCornerAtOtherOctave(*frame, best) && best.best > options.ratio * best.second) {
      continue;
    }
    if (best.best < scratch->best_distance_per_keypoint[best.best_index]) {
      scratch->best_distance_per_keypoint[best.best_index] = best.best;
      scratch->line_per_keypoint[best.best_index] = c;
      scratch->sample_s_per_keypoint[best.best_index] = best.best_sample_s;
    }
  }

  int num_matches = 0;
  for (int i = 0; i < num_keypoints; ++i) {
    const int c = scratch->line_per_keypoint[i];
    if (c < 0) continue;
    const LineMatchCandidate& candidate = lines[c];
    frame->landmark_ids[i] = candidate.line_id;
    frame->is_outlier[i] = 0;
    ++num_matches;
    if (matches_out == nullptr) continue;
    LineMatch match;
    match.keypoint_index = i;
    match.line_id = candidate.line_id;
    match.sample_s = scratch->sample_s_per_keypoint[i];
    match.s = match.sample_s;
    const Eigen::Vector3d& bearing = frame->bearings[i];
    if (bearing.squaredNorm() > 0.5) {
      const Line3d line_in_cam(R * candidate.line.anchor + t, R * candidate.line.direction);
      const Line3d ray(Eigen::Vector3d::Zero(), bearing);
      const std::optional<ClosestPoints> closest =
          ClosestPointsBetweenLines(line_in_cam, ray, 1e-6);
      if (closest && closest->s_b > 0.0) {
        match.s = std::clamp(closest->s_a, candidate.s_min, candidate.s_max);
      }
    }
    matches_out->push_back(match);
  }
  return num_matches;
}

}  // namespace lcv::slam
