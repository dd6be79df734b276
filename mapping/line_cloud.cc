#include "mapping/line_cloud.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using slam::Id;

// The anchor rule (see the header): the foot of the perpendicular from the map origin. It depends
// only on the line as a set of points, never on where on it the hidden point lies.
Eigen::Vector3d CanonicalAnchor(const Eigen::Vector3d& point_on_line,
                                const Eigen::Vector3d& direction) {
  return point_on_line - direction.dot(point_on_line) * direction;
}

// Grid cell of a position for a neighbour search at radius cell_size.
std::array<std::int64_t, 3> Cell(const Eigen::Vector3d& p, double cell_size) {
  return {static_cast<std::int64_t>(std::floor(p.x() / cell_size)),
          static_cast<std::int64_t>(std::floor(p.y() / cell_size)),
          static_cast<std::int64_t>(std::floor(p.z() / cell_size))};
}

// 5e-5 x the median distance of the points from their per-axis median: ~1.5 mm for a street
// seen from 30 m. Not the bounding box: a few far points (an equirectangular map triangulates
// points near the horizon hundreds of metres away) made it metres, and 2606 of 2632 points of
// a synthetic street collapsed into 5 lines.
double DefaultCoincidentDistance(const slam::Map& map) {
  if (map.points.empty()) return 0.0;
  std::vector<double> axis[3];
  for (const auto& [id, p] : map.points) {
    for (int d = 0; d < 3; ++d) axis[d].push_back(p.position[d]);
  }
  Eigen::Vector3d median;
  for (int d = 0; d < 3; ++d) {
    std::nth_element(axis[d].begin(), axis[d].begin() + axis[d].size() / 2, axis[d].end());
    median[d] = axis[d][axis[d].size() / 2];
  }
  std::vector<double> radius;
  for (const auto& [id, p] : map.points) radius.push_back((p.position - median).norm());
  std::nth_element(radius.begin(), radius.begin() + radius.size() / 2, radius.end());
  return 5e-5 * radius[radius.size() / 2];
}

}  // namespace

slam::Map MergeCoincidentPoints(const slam::Map& point_map, double distance,
                                LineCloudReport* report) {
  slam::Map out = point_map;
  if (!(distance > 0.0) || point_map.points.size() < 2) return out;
  std::map<std::array<std::int64_t, 3>, std::vector<Id>> grid;
  for (const auto& [id, p] : point_map.points) grid[Cell(p.position, distance)].push_back(id);
  std::map<Id, Id> parent;  // union-find towards the smallest id
  std::function<Id(Id)> find = [&](Id x) {
    auto it = parent.find(x);
    if (it == parent.end() || it->second == x) return x;
    const Id root = find(it->second);
    it->second = root;
    return root;
  };
  const double distance_sq = distance * distance;
  for (const auto& [id, p] : point_map.points) {
    const auto c = Cell(p.position, distance);
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy)
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == grid.end()) continue;
          for (Id other : it->second) {
            if (other <= id) continue;
            if ((point_map.points.at(other).position - p.position).squaredNorm() > distance_sq)
              continue;
            const Id a = find(id), b = find(other);
            if (a != b) parent[std::max(a, b)] = std::min(a, b);
          }
        }
  }
  std::map<Id, std::vector<Id>> groups;
  for (const auto& [id, p] : point_map.points) groups[find(id)].push_back(id);
  for (auto& [root, members] : groups) {
    if (members.size() < 2) continue;
    std::sort(members.begin(), members.end());
    slam::PointLandmark& kept = out.points.at(root);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
    for (Id m : members) {
      const slam::PointLandmark& p = point_map.points.at(m);
      sum += p.position;
      information += p.covariance.inverse();
      if (m != root) {
        kept.observations.insert(kept.observations.end(), p.observations.begin(),
                                 p.observations.end());
        out.points.erase(m);
      }
    }
    kept.position = sum / static_cast<double>(members.size());
    const Eigen::Matrix3d covariance = information.inverse();
    if (covariance.allFinite()) kept.covariance = 0.5 * (covariance + covariance.transpose());
    if (report) {
      ++report->coincident_groups;
      report->points_merged_away += static_cast<int>(members.size()) - 1;
    }
  }
  return out;
}

slam::Map ConvertToLineCloud(const slam::Map& point_map_in, const LineCloudOptions& options,
                             LineCloudReport* report) {
  const double coincident = options.coincident_distance < 0.0
                                ? DefaultCoincidentDistance(point_map_in)
                                : options.coincident_distance;
  const slam::Map merged_points = MergeCoincidentPoints(point_map_in, coincident, report);
  const slam::Map& point_map = merged_points;
  slam::Map out;
  out.cameras = point_map.cameras;
  out.description = point_map.description;
  out.server_keyframes = point_map.server_keyframes;

  // Lines already in the map: keep the line, drop what a client attached to it (X', x').
  for (const auto& [id, line] : point_map.lines) {
    slam::LineLandmark kept = line;
    kept.restored_point.reset();
    kept.observations.clear();
    kept.line.anchor = CanonicalAnchor(line.line.anchor, line.line.direction);
    for (const slam::Observation& obs : line.observations) {
      kept.server_keyframe_ids.push_back(obs.keyframe_id);
    }
    out.lines.emplace(id, std::move(kept));
  }

  // Points -> lines. Directions come from the seeded RNG in id order and nothing else.
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (const auto& [id, point] : point_map.points) {
    LCV_CHECK(!out.lines.count(id)) << "point id " << id << " is also a line id";
    slam::LineLandmark line;
    line.id = id;
    const double u = uniform(rng);
    const double v = uniform(rng);
    line.line.direction = slam::UniformUnitVector(u, v).normalized();
    line.line.anchor = CanonicalAnchor(point.position, line.line.direction);
    if (options.information == LineInformationRule::kPointCovariance) {
      line.information = slam::LineInformation(line.line.direction, point.covariance);
    }
    line.descriptor = point.descriptor;
    for (const slam::Observation& obs : point.observations) {
      line.server_keyframe_ids.push_back(obs.keyframe_id);
    }
    out.lines.emplace(id, std::move(line));
  }

  // Client keyframes -> server keyframes: pose and timestamp only.
  for (const auto& [id, kf] : point_map.keyframes) {
    LCV_CHECK(!out.server_keyframes.count(id))
        << "keyframe id " << id << " is also a server keyframe id";
    slam::ServerKeyframe server;
    server.id = id;
    server.camera_id = kf.camera_id;
    server.timestamp = kf.timestamp;
    server.cam_from_world = kf.cam_from_world;
    out.server_keyframes.emplace(id, std::move(server));
  }

  // Visibility both ways, sorted and unique: the union of what lines and server keyframes list,
  // without ids that do not exist.
  std::set<std::pair<Id, Id>> seen;  // (server keyframe id, line id)
  for (const auto& [line_id, line] : out.lines) {
    for (Id kf : line.server_keyframe_ids) seen.emplace(kf, line_id);
  }
  for (const auto& [kf_id, kf] : out.server_keyframes) {
    for (Id line_id : kf.line_ids) seen.emplace(kf_id, line_id);
  }
  for (auto& [line_id, line] : out.lines) line.server_keyframe_ids.clear();
  for (auto& [kf_id, kf] : out.server_keyframes) kf.line_ids.clear();
  for (const auto& [kf_id, line_id] : seen) {
    const auto kf = out.server_keyframes.find(kf_id);
    const auto line = out.lines.find(line_id);
    if (kf == out.server_keyframes.end() || line == out.lines.end()) continue;
    kf->second.line_ids.push_back(line_id);  // ascending: the set is ordered by (kf, line)
    line->second.server_keyframe_ids.push_back(kf_id);
  }
  for (auto& [line_id, line] : out.lines) {
    std::sort(line.server_keyframe_ids.begin(), line.server_keyframe_ids.end());
  }
  if (options.information == LineInformationRule::kProxyPoint) SetProxyInformation(&out);
  return out;
}

namespace {

struct ProxyView {
  Eigen::Vector3d centre;
  double pixel_angle = 0.0;
};

// The server keyframes that list the line, with a camera of known pixel angle.
std::vector<ProxyView> ProxyViews(const slam::Map& map, const slam::LineLandmark& line) {
  std::vector<ProxyView> views;
  for (Id kf_id : line.server_keyframe_ids) {
    const auto kf = map.server_keyframes.find(kf_id);
    if (kf == map.server_keyframes.end()) continue;
    const auto camera = map.cameras.find(kf->second.camera_id);
    if (camera == map.cameras.end()) continue;
    const double angle = slam::PixelAngle(camera->second);
    if (angle > 0.0) views.push_back({kf->second.cam_from_world.Center(), angle});
  }
  return views;
}

// The point of the line closest to the views' centres (least squares): the foot of the
// perpendicular from their mean.
Eigen::Vector3d ProxyPoint(const slam::Line3d& line, const std::vector<ProxyView>& views) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const ProxyView& v : views) mean += v.centre;
  mean /= static_cast<double>(views.size());
  return line.anchor + line.direction.dot(mean - line.anchor) * line.direction;
}

// kProxyPoint's floor from every line's views (ProxyViews, in map.lines order).
double FloorOfViews(const slam::Map& map, const std::vector<std::vector<ProxyView>>& all_views) {
  std::vector<double> distances;
  auto views = all_views.begin();
  for (const auto& [id, line] : map.lines) {
    const std::vector<ProxyView>& line_views = *views++;
    if (line_views.empty()) continue;
    const Eigen::Vector3d x = ProxyPoint(line.line, line_views);
    for (const ProxyView& v : line_views) distances.push_back((x - v.centre).norm());
  }
  if (distances.empty()) return 1.0;
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
  const double floor = kProxyDistanceFloor * distances[distances.size() / 2];
  return floor > 0.0 && std::isfinite(floor) ? floor : 1.0;
}

std::vector<std::vector<ProxyView>> AllProxyViews(const slam::Map& map) {
  std::vector<std::vector<ProxyView>> all;
  all.reserve(map.lines.size());
  for (const auto& [id, line] : map.lines) all.push_back(ProxyViews(map, line));
  return all;
}

// kProxyPoint's Omega_L of line from its views.
Eigen::Matrix3d InformationOfViews(const slam::Map& map, const slam::LineLandmark& line,
                                   const std::vector<ProxyView>& views, double distance_floor) {
  LCV_CHECK(distance_floor > 0.0);
  const Eigen::Vector3d d = line.line.direction.normalized();
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  double largest = distance_floor;
  if (views.empty()) {
    // Seen by no keyframe: one view at the floor distance with the map's first camera.
    double angle = 1e-3;
    for (const auto& [id, camera] : map.cameras) {
      if (slam::PixelAngle(camera) > 0.0) {
        angle = slam::PixelAngle(camera);
        break;
      }
    }
    information = Eigen::Matrix3d::Identity() / std::pow(distance_floor * angle, 2);
  } else {
    const Eigen::Vector3d x = ProxyPoint(line.line, views);
    for (const ProxyView& v : views) {
      const Eigen::Vector3d ray = x - v.centre;
      const double rho = std::max(ray.norm(), distance_floor);
      // A line through the camera centre: the ray is any direction across the line.
      const Eigen::Vector3d bearing =
          ray.norm() > 0.0 ? Eigen::Vector3d(ray.normalized()) : Eigen::Vector3d(d.unitOrthogonal());
      information += (Eigen::Matrix3d::Identity() - bearing * bearing.transpose()) /
                     std::pow(rho * v.pixel_angle, 2);
      largest = std::max(largest, rho);
    }
  }
  information += Eigen::Matrix3d::Identity() / (largest * largest);  // the prior
  const Eigen::Matrix3d covariance = information.ldlt().solve(Eigen::Matrix3d::Identity());
  return slam::LineInformation(d, 0.5 * (covariance + covariance.transpose()));
}

}  // namespace

double ProxyDistanceFloor(const slam::Map& map) { return FloorOfViews(map, AllProxyViews(map)); }

Eigen::Matrix3d ProxyLineInformation(const slam::Map& map, const slam::LineLandmark& line,
                                     double distance_floor) {
  return InformationOfViews(map, line, ProxyViews(map, line), distance_floor);
}

void SetProxyInformation(slam::Map* map) {
  LCV_CHECK(map != nullptr);
  const std::vector<std::vector<ProxyView>> all_views = AllProxyViews(*map);  // once per line
  const double floor = FloorOfViews(*map, all_views);
  auto views = all_views.begin();
  for (auto& [id, line] : map->lines) {
    line.information = InformationOfViews(*map, line, *views++, floor);
  }
}

void ReapplyInformationRule(const LineCloudOptions& options, slam::Map* map) {
  if (options.information == LineInformationRule::kProxyPoint) SetProxyInformation(map);
}

}  // namespace lcv::mapping
