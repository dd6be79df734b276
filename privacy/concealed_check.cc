#include "privacy/concealed_check.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

#include "privacy/line_grid.h"

namespace lcv::privacy {
namespace {

struct ConcealedLine {
  slam::Id id;
  slam::Line3d line;
  double s_min, s_max;   // the checked part
  std::string region;    // empty for listed lines
  int region_index;      // -1 for listed lines
};

double DistanceToPart(const ConcealedLine& c, const Eigen::Vector3d& x) {
  const double s = std::clamp(c.line.Parameter(x), c.s_min, c.s_max);
  return (x - c.line.PointAt(s)).norm();
}

// X and X' of the client map, with the id that names them in a report.
struct ClientPoint {
  std::string kind;  // "point_near_concealed_line" or "restored_point_near_concealed_line"
  slam::Id id;
  Eigen::Vector3d position;
  const slam::PointLandmark* landmark = nullptr;  // for X: its observations
};

using CameraById = std::map<slam::Id, std::unique_ptr<slam::Camera>>;

// One observation of a client point, with its acceptance gate in squared pixels.
struct GatedObservation {
  const slam::Camera* camera;
  const slam::Keyframe* keyframe;
  Eigen::Vector2d keypoint;
  double max_squared_px;
};

bool Accepts(const GatedObservation& o, const Eigen::Vector3d& x) {
  const auto px = o.camera->Project(o.keyframe->cam_from_world * x);
  return px && (*px - o.keypoint).squaredNorm() <= o.max_squared_px;
}

// ConcealedCheckOptions::clear_points_by_observations: does a position along the point's ray
// that all its observations accept lie outside the zone (in_zone false)?
template <typename InZone>
bool ObservationsAllowOutside(const slam::PointLandmark& point, const slam::Map& client,
                              const CameraById& cameras, const ConcealedCheckOptions& options,
                              const InZone& in_zone) {
  constexpr double kChi2TwoDof95 = 5.991;
  std::vector<GatedObservation> gated;
  Eigen::Vector3d centres = Eigen::Vector3d::Zero();
  for (const slam::Observation& obs : point.observations) {
    auto kf = client.keyframes.find(obs.keyframe_id);
    if (kf == client.keyframes.end() || obs.keypoint_index >= kf->second.keypoints.size()) continue;
    auto cam = cameras.find(kf->second.camera_id);
    if (cam == cameras.end()) continue;
    const slam::Keypoint& kp = kf->second.keypoints[obs.keypoint_index];
    const double sigma = std::pow(options.pyramid_scale_factor, kp.octave);
    gated.push_back({cam->second.get(), &kf->second, Eigen::Vector2d(kp.x, kp.y),
                     kChi2TwoDof95 * sigma * sigma});
    centres += kf->second.cam_from_world.Center();
  }
  if (gated.size() < 2) return false;
  auto accepted = [&](const Eigen::Vector3d& x) {
    return std::all_of(gated.begin(), gated.end(),
                       [&](const GatedObservation& o) { return Accepts(o, x); });
  };
  if (!accepted(point.position)) return false;
  const Eigen::Vector3d ray = point.position - centres / static_cast<double>(gated.size());
  if (!(ray.norm() > 0.0)) return false;
  const Eigen::Vector3d u = ray.normalized();
  const double step = options.epsilon_m / 20.0;
  for (const double sign : {-1.0, 1.0}) {
    for (int i = 1; i <= 4000; ++i) {
      const Eigen::Vector3d y = point.position + sign * i * step * u;
      if (!accepted(y)) break;
      if (!in_zone(y)) return true;
    }
  }
  return false;
}

}  // namespace

ConcealedCheckResult CheckConcealedLines(const slam::Map& published, const slam::Map& client,
                                         const ConcealedSpec& spec,
                                         const ReferenceMatch* reference_match,
                                         const ConcealedCheckOptions& options) {
  ConcealedCheckResult out;
  // Hidden points of the published lines (by id) when a reference is given.
  std::map<slam::Id, Eigen::Vector3d> hidden;
  if (reference_match) {
    std::size_t i = 0;
    for (const auto& [id, l] : published.lines) {
      if (i < reference_match->matched.size() && reference_match->matched[i]) {
        hidden[id] = reference_match->hidden_points[i];
      }
      ++i;
    }
  }
  // All lines known to either map, the published version first.
  std::map<slam::Id, slam::Line3d> lines;
  for (const auto& [id, l] : client.lines) lines[id] = l.line;
  for (const auto& [id, l] : published.lines) lines[id] = l.line;

  std::vector<ConcealedLine> concealed;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (slam::Id id : spec.line_ids) {
    auto it = lines.find(id);
    if (it != lines.end()) concealed.push_back({id, it->second, -kInf, kInf, "", -1});
  }
  for (std::size_t r = 0; r < spec.regions.size(); ++r) {
    const ConcealedRegion& region = spec.regions[r];
    for (const auto& [id, line] : lines) {
      auto h = hidden.find(id);
      if (h != hidden.end() && !region.box.contains(h->second)) continue;
      double s0, s1;
      if (!ClipLineToBox(line, region.box, &s0, &s1)) continue;
      concealed.push_back({id, line, s0, s1, region.name, static_cast<int>(r)});
    }
  }
  {
    std::vector<slam::Id> ids;
    for (const auto& c : concealed) ids.push_back(c.id);
    std::sort(ids.begin(), ids.end());
    out.num_concealed_lines = static_cast<int>(std::unique(ids.begin(), ids.end()) - ids.begin());
  }

  std::vector<ClientPoint> points;
  for (const auto& [id, p] : client.points) {
    points.push_back({"point_near_concealed_line", id, p.position, &p});
  }
  out.num_points_checked = static_cast<int>(client.points.size());
  for (const auto& [id, l] : client.lines) {
    if (!l.restored_point) continue;
    points.push_back({"restored_point_near_concealed_line", id, *l.restored_point});
    ++out.num_restored_points_checked;
  }

  // Per region, only the client points in its box (grown by the margin, see the header) are
  // checked against its lines' parts; without a margin, those within epsilon of the box.
  const double eps = options.epsilon_m;
  const double margin = options.point_region_margin_m >= 0 ? options.point_region_margin_m : eps;
  std::vector<std::vector<std::size_t>> near_region(spec.regions.size());
  std::vector<Eigen::AlignedBox3d> checked_box(spec.regions.size());
  for (std::size_t r = 0; r < spec.regions.size(); ++r) {
    const ConcealedRegion& region = spec.regions[r];
    const Eigen::Array3d shrink_min = region.rests_min.select(Eigen::Array3d::Constant(margin),
                                                              Eigen::Array3d::Constant(-margin));
    const Eigen::Array3d shrink_max = region.rests_max.select(Eigen::Array3d::Constant(margin),
                                                              Eigen::Array3d::Constant(-margin));
    const Eigen::AlignedBox3d grown(region.box.min() + shrink_min.matrix(),
                                    region.box.max() - shrink_max.matrix());
    checked_box[r] = grown;
    for (std::size_t k = 0; k < points.size(); ++k) {
      if (grown.contains(points[k].position)) near_region[r].push_back(k);
    }
  }
  CameraById cameras;
  for (const auto& [id, params] : client.cameras) {
    if (!params.Problem()) cameras[id] = slam::MakeCamera(params);
  }
  // The zone a client point must not be in: within epsilon of a concealed line's checked part,
  // inside that line's region (as grown or shrunk above).
  auto in_zone = [&](const Eigen::Vector3d& y) {
    for (const ConcealedLine& c : concealed) {
      if (c.region_index >= 0 && !checked_box[c.region_index].contains(y)) continue;
      if (DistanceToPart(c, y) <= eps) return true;
    }
    return false;
  };
  std::vector<signed char> cleared(points.size(), -1);  // -1: not decided yet
  auto is_cleared = [&](std::size_t k) {
    if (!options.clear_points_by_observations || points[k].landmark == nullptr) return false;
    if (cleared[k] < 0) {
      cleared[k] = ObservationsAllowOutside(*points[k].landmark, client, cameras, options, in_zone);
      out.num_points_cleared_by_observations += cleared[k];
    }
    return cleared[k] == 1;
  };
  for (const ConcealedLine& c : concealed) {
    auto check = [&](std::size_t k) {
      const double d = DistanceToPart(c, points[k].position);
      if (d > eps) return;
      if (is_cleared(k)) return;
      ConcealedViolation v;
      v.kind = points[k].kind;
      v.point_id = points[k].id;
      v.line_id = c.id;
      v.region = c.region;
      v.position = points[k].position;
      v.distance_m = d;
      out.violations.push_back(v);
    };
    if (c.region_index >= 0) {
      for (std::size_t k : near_region[c.region_index]) check(k);
    } else {
      for (std::size_t k = 0; k < points.size(); ++k) check(k);
    }
  }

  // Every X' must rest on real client observations.
  for (const auto& [id, l] : client.lines) {
    if (!l.restored_point) continue;
    std::string reason;
    int supported = 0;
    for (const slam::Observation& obs : l.observations) {
      auto kf = client.keyframes.find(obs.keyframe_id);
      if (kf == client.keyframes.end()) {
        reason = "observation names missing keyframe " + std::to_string(obs.keyframe_id);
        continue;
      }
      if (obs.keypoint_index >= kf->second.keypoints.size()) {
        reason = "observation names missing keypoint " + std::to_string(obs.keypoint_index) +
                 " of keyframe " + std::to_string(obs.keyframe_id);
        continue;
      }
      auto cam = cameras.find(kf->second.camera_id);
      if (cam == cameras.end()) {
        reason = "keyframe " + std::to_string(obs.keyframe_id) + " has no usable camera";
        continue;
      }
      const auto px = cam->second->Project(kf->second.cam_from_world * *l.restored_point);
      const slam::Keypoint& kp = kf->second.keypoints[obs.keypoint_index];
      const double err =
          px ? (*px - Eigen::Vector2d(kp.x, kp.y)).norm() : std::numeric_limits<double>::infinity();
      if (err > options.max_reprojection_px) {
        reason = "X' reprojects " + (px ? std::to_string(err) + " px" : std::string("behind")) +
                 " from its keypoint in keyframe " + std::to_string(obs.keyframe_id);
        continue;
      }
      ++supported;
    }
    if (supported >= options.min_observations) continue;
    ConcealedViolation v;
    v.kind = "restored_point_without_observations";
    v.point_id = id;
    v.position = *l.restored_point;
    v.reason = l.observations.empty() ? "no client observations" : reason;
    if (supported > 0) {
      v.reason = std::to_string(supported) + " supporting observations, fewer than " +
                 std::to_string(options.min_observations);
    }
    out.violations.push_back(v);
  }
  return out;
}

}  // namespace lcv::privacy
