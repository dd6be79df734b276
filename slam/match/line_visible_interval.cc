// LineVisibleInterval (declared in slam/match/line_projection_matcher.h): where on a published
// line its hidden point can lie, from the server keyframes that saw it.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "slam/match/line_projection_matcher.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

using Interval = std::pair<double, double>;

// Sampling of one keyframe's view of the line: 0.5 degree of bearing angle (the angle a line
// segment spans seen from the centre), at least kMinSamples samples per keyframe.
constexpr double kSampleAngleRad = 0.5 * M_PI / 180.0;
constexpr int kMinSamples = 16;
constexpr int kBisections = 60;

// Parts of [lo, hi] where visible(s) holds, found by sampling s at parameters from sample_at(u),
// u in [0, 1] increasing, then bisecting each change of visibility.
template <typename Visible, typename SampleAt>
std::vector<Interval> VisiblePieces(double lo, double hi, int num_samples, const Visible& visible,
                                    const SampleAt& sample_at) {
  std::vector<Interval> pieces;
  const double tolerance = 1e-9 * std::max(hi - lo, 1e-12);
  // Boundary between s_a (visibility state_a) and s_b (the other state).
  const auto bisect = [&](double s_a, double s_b, bool state_a) {
    for (int i = 0; i < kBisections && std::abs(s_b - s_a) > tolerance; ++i) {
      const double mid = 0.5 * (s_a + s_b);
      (visible(mid) == state_a ? s_a : s_b) = mid;
    }
    return state_a ? s_a : s_b;  // the boundary on the visible side
  };
  double previous_s = lo;
  bool previous_visible = visible(lo);
  double piece_start = lo;
  for (int k = 1; k <= num_samples; ++k) {
    const double s = k == num_samples ? hi : std::clamp(sample_at(double(k) / num_samples), lo, hi);
    const bool now_visible = visible(s);
    if (now_visible != previous_visible) {
      const double boundary = bisect(previous_s, s, previous_visible);
      if (now_visible) {
        piece_start = boundary;
      } else {
        pieces.emplace_back(piece_start, boundary);
      }
    }
    previous_s = s;
    previous_visible = now_visible;
  }
  if (previous_visible) pieces.emplace_back(piece_start, hi);
  return pieces;
}

std::vector<Interval> Intersect(const std::vector<Interval>& a, const std::vector<Interval>& b) {
  std::vector<Interval> out;
  for (const Interval& x : a) {
    for (const Interval& y : b) {
      const double lo = std::max(x.first, y.first), hi = std::min(x.second, y.second);
      if (lo <= hi) out.emplace_back(lo, hi);
    }
  }
  return out;
}

}  // namespace

std::optional<std::pair<double, double>> LineVisibleInterval(
    const Line3d& line, const std::vector<Rigid3d>& server_cam_from_world,
    const std::vector<const Camera*>& cameras, double min_distance, double max_distance) {
  LCV_CHECK(server_cam_from_world.size() == cameras.size())
      << server_cam_from_world.size() << " poses, " << cameras.size() << " cameras";
  LCV_CHECK(min_distance >= 0.0 && min_distance < max_distance && std::isfinite(max_distance))
      << "distances [" << min_distance << ", " << max_distance << "]";
  for (const Camera* camera : cameras) LCV_CHECK(camera != nullptr);
  if (server_cam_from_world.empty()) return std::nullopt;

  // The distance bound is a ball around each centre: its chord on the line is analytic.
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  for (const Rigid3d& cam_from_world : server_cam_from_world) {
    const Eigen::Vector3d center = cam_from_world.Center();
    const double s_foot = line.Parameter(center);
    const double h = line.Distance(center);
    if (h > max_distance) return std::nullopt;
    const double half_chord = std::sqrt(max_distance * max_distance - h * h);
    lo = std::max(lo, s_foot - half_chord);
    hi = std::min(hi, s_foot + half_chord);
  }
  if (!(lo <= hi)) return std::nullopt;

  std::vector<Interval> feasible = {{lo, hi}};
  for (size_t k = 0; k < cameras.size() && !feasible.empty(); ++k) {
    const Rigid3d& cam_from_world = server_cam_from_world[k];
    const Camera& camera = *cameras[k];
    const Eigen::Vector3d anchor_in_cam = cam_from_world * line.anchor;
    const Eigen::Vector3d dir = cam_from_world.rotation * line.direction;
    const auto visible = [&](double s) {
      const Eigen::Vector3d p_in_cam = anchor_in_cam + s * dir;
      const double distance = p_in_cam.norm();
      if (distance < min_distance || distance > max_distance) return false;
      const std::optional<Eigen::Vector2d> px = camera.Project(p_in_cam);
      return px.has_value() && camera.InImage(*px);
    };
    // Sample the current hull uniformly in bearing angle as seen from this keyframe: s = s_foot
    // + h tan(phi). A line through the centre (h ~ 0) is sampled uniformly in s instead.
    const double hull_lo = feasible.front().first, hull_hi = feasible.back().second;
    const double s_foot = -anchor_in_cam.dot(dir);
    const double h = (anchor_in_cam + s_foot * dir).norm();
    std::vector<Interval> pieces;
    if (h > 1e-9 * (1.0 + std::abs(hull_hi - hull_lo))) {
      const double phi_lo = std::atan((hull_lo - s_foot) / h);
      const double phi_hi = std::atan((hull_hi - s_foot) / h);
      const int n =
          std::max(kMinSamples, static_cast<int>(std::ceil((phi_hi - phi_lo) / kSampleAngleRad)));
      pieces = VisiblePieces(hull_lo, hull_hi, n, visible, [&](double u) {
        return s_foot + h * std::tan(phi_lo + u * (phi_hi - phi_lo));
      });
    } else {
      pieces = VisiblePieces(hull_lo, hull_hi, 2 * kMinSamples, visible,
                             [&](double u) { return hull_lo + u * (hull_hi - hull_lo); });
    }
    feasible = Intersect(feasible, pieces);
  }
  if (feasible.empty()) return std::nullopt;
  double out_lo = feasible.front().first, out_hi = feasible.front().second;
  for (const Interval& piece : feasible) {
    out_lo = std::min(out_lo, piece.first);
    out_hi = std::max(out_hi, piece.second);
  }
  return std::make_pair(out_lo, out_hi);
}

}  // namespace lcv::slam
