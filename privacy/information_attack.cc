#include "privacy/information_attack.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Eigenvalues>

#include "mapping/line_cloud.h"
#include "privacy/parallel.h"
#include "slam/camera/camera.h"

namespace lcv::privacy {
namespace {

struct View {
  const slam::Camera* camera = nullptr;
  slam::Rigid3d cam_from_world;
  double angle = 0.0;  // sigma per unit of distance
};

bool Images(const View& view, const Eigen::Vector3d& point_in_world) {
  const Eigen::Vector3d p = view.cam_from_world * point_in_world;
  const auto px = view.camera->Project(p);
  return px && view.camera->InImage(*px);
}

}  // namespace

LineAttackResult RunInformationAttack(const slam::Map& map,
                                      const InformationAttackOptions& options) {
  LineAttackResult result;
  result.name = "information";
  result.Resize(map.lines.size());
  std::vector<const slam::LineLandmark*> lines;
  for (const auto& [id, line] : map.lines) {
    result.line_ids[lines.size()] = id;
    lines.push_back(&line);
  }
  std::map<slam::Id, std::unique_ptr<slam::Camera>> cameras;
  for (const auto& [id, params] : map.cameras) {
    if (!params.Problem()) cameras[id] = slam::MakeCamera(params);
  }
  std::map<slam::Id, View> views;
  for (const auto& [id, kf] : map.server_keyframes) {
    const auto camera = cameras.find(kf.camera_id);
    if (camera == cameras.end()) continue;
    const double angle = options.angle_per_distance > 0.0
                             ? options.angle_per_distance
                             : slam::PixelAngle(map.cameras.at(kf.camera_id));
    if (angle > 0.0) views[id] = View{camera->second.get(), kf.cam_from_world, angle};
  }

  const double proxy_floor = mapping::ProxyDistanceFloor(map);
  ParallelBlocks(lines.size(), ResolveThreadCount(options.num_threads),
                 [&](std::size_t begin, std::size_t end, int) {
    std::vector<const View*> seen_by;
    std::vector<Eigen::Vector3d> kept;
    for (std::size_t i = begin; i < end; ++i) {
      const slam::LineLandmark& line = *lines[i];
      seen_by.clear();
      for (slam::Id k : line.server_keyframe_ids) {  // sorted by the map reader's invariant
        const auto v = views.find(k);
        if (v != views.end()) seen_by.push_back(&v->second);
      }
      if (seen_by.empty()) continue;
      const double largest =
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(line.information, Eigen::EigenvaluesOnly)
              .eigenvalues()
              .maxCoeff();
      if (!(largest > 0.0) || !std::isfinite(largest)) continue;
      const double sigma = 1.0 / std::sqrt(largest);
      // Omega_L made from published data (mapping's kProxyPoint rule) says nothing new.
      const Eigen::Matrix3d proxy = mapping::ProxyLineInformation(map, line, proxy_floor);
      if ((line.information - proxy).norm() <= 1e-9 * proxy.norm()) continue;
      const Eigen::Vector3d& d = line.line.direction;
      kept.clear();
      for (const View* view : seen_by) {
        const double radius = sigma / view->angle;
        // |anchor + s d - C|^2 = radius^2: s = -b -+ sqrt(b^2 - c).
        const Eigen::Vector3d w = line.line.anchor - view->cam_from_world.Center();
        const double b = w.dot(d);
        const double disc = b * b - (w.squaredNorm() - radius * radius);
        if (disc < 0.0) continue;
        const double root = std::sqrt(disc);
        for (double s : {-b - root, -b + root}) {
          const Eigen::Vector3d candidate = line.line.anchor + s * d;
          const bool imaged = std::all_of(seen_by.begin(), seen_by.end(),
                                          [&](const View* v) { return Images(*v, candidate); });
          if (imaged) kept.push_back(candidate);
        }
      }
      if (kept.empty()) continue;
      result.has_estimate[i] = 1;
      result.estimates[i] = kept.front();
      result.risk[i] = 1.0 / static_cast<double>(kept.size());
    }
  });
  return result;
}

}  // namespace lcv::privacy
