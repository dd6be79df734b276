#include "privacy/visibility_attack.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "privacy/parallel.h"
#include "privacy/scene_box.h"

namespace lcv::privacy {
namespace {

struct View {
  const slam::Camera* camera = nullptr;
  slam::Rigid3d cam_from_world;
};

// The visible parameter interval of line in one view, searched inside [*lo_out, *hi_out] (the
// interval so far: later views only refine it), or false.
bool VisibleInterval(const slam::Line3d& line, const View& view, double near_m, double far_m,
                     int samples, double* lo_out, double* hi_out) {
  const Eigen::Vector3d p = view.cam_from_world * line.anchor;  // L(0) in the camera frame
  const Eigen::Vector3d d = view.cam_from_world.rotation * line.direction;
  // |p + s d|^2 <= far^2: s in s_c -+ sqrt(far^2 - r^2).
  const double s_c = -p.dot(d);
  const double r_sq = p.squaredNorm() - s_c * s_c;
  const double far_sq = far_m * far_m;
  if (r_sq >= far_sq) return false;
  const double half = std::sqrt(far_sq - r_sq);
  const double lo = std::max(s_c - half, *lo_out), hi = std::min(s_c + half, *hi_out);
  if (!(hi > lo)) return false;
  const slam::Camera& cam = *view.camera;
  const double near_sq = near_m * near_m;
  auto visible = [&](double s) {
    const Eigen::Vector3d x = p + s * d;
    if (x.squaredNorm() < near_sq) return false;
    const auto px = cam.Project(x);
    return px && cam.InImage(*px);
  };
  int first = -1, last = -1;
  const double step = (hi - lo) / (samples - 1);
  for (int k = 0; k < samples; ++k) {
    if (visible(lo + k * step)) {
      if (first < 0) first = k;
      last = k;
    }
  }
  if (first < 0) return false;
  // Bisect the run's ends between the last invisible and first visible samples.
  auto refine = [&](double in, double out) {
    for (int it = 0; it < 14; ++it) {
      const double mid = 0.5 * (in + out);
      (visible(mid) ? in : out) = mid;
    }
    return in;
  };
  *lo_out = first == 0 ? lo : refine(lo + first * step, lo + (first - 1) * step);
  *hi_out = last == samples - 1 ? hi : refine(lo + last * step, lo + (last + 1) * step);
  return true;
}

}  // namespace

LineAttackResult RunVisibilityAttack(const slam::Map& map, const VisibilityAttackOptions& options) {
  LineAttackResult result;
  result.name = "visibility";
  const std::size_t n = map.lines.size();
  result.Resize(n);

  std::vector<const slam::LineLandmark*> lines;
  std::map<slam::Id, std::size_t> index_of;
  for (const auto& [id, l] : map.lines) {
    result.line_ids[lines.size()] = id;
    index_of[id] = lines.size();
    lines.push_back(&l);
  }
  // Views, and per line the keyframes that see it (both lists of the map, deduplicated).
  std::map<slam::Id, std::unique_ptr<slam::Camera>> cameras;
  for (const auto& [id, params] : map.cameras) {
    if (!params.Problem()) cameras[id] = slam::MakeCamera(params);
  }
  std::map<slam::Id, View> views;
  for (const auto& [id, kf] : map.server_keyframes) {
    auto cam = cameras.find(kf.camera_id);
    if (cam != cameras.end()) views[id] = View{cam->second.get(), kf.cam_from_world};
  }
  std::vector<std::vector<std::pair<slam::Id, const View*>>> seen_by(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (slam::Id k : lines[i]->server_keyframe_ids) {
      auto v = views.find(k);
      if (v != views.end()) seen_by[i].emplace_back(k, &v->second);
    }
  }
  for (const auto& [id, kf] : map.server_keyframes) {
    auto v = views.find(id);
    if (v == views.end()) continue;
    for (slam::Id line_id : kf.line_ids) {
      auto it = index_of.find(line_id);
      if (it != index_of.end()) seen_by[it->second].emplace_back(id, &v->second);
    }
  }
  for (auto& list : seen_by) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }

  double far_m = options.far_m;
  double tau = options.risk_tolerance_m;
  if (far_m <= 0 || tau <= 0) {
    std::vector<slam::Line3d> bare;
    bare.reserve(n);
    for (const auto* l : lines) bare.push_back(l->line);
    std::vector<Eigen::Vector3d> centers;
    for (const auto& [id, v] : views) centers.push_back(v.cam_from_world.Center());
    SceneBoxOptions box_options;
    box_options.num_threads = options.num_threads;
    const Eigen::AlignedBox3d box = EstimateSceneBox(bare, centers, box_options);
    const double diagonal = box.isEmpty() ? 1.0 : box.diagonal().norm();
    if (far_m <= 0) far_m = diagonal;
    if (tau <= 0) tau = 0.01 * diagonal;
  }
  const int samples = std::max(4, options.samples_per_keyframe);
  ParallelBlocks(n, ResolveThreadCount(options.num_threads),
                 [&](std::size_t begin, std::size_t end, int) {
    for (std::size_t i = begin; i < end; ++i) {
      if (seen_by[i].empty()) continue;
      double lo = -std::numeric_limits<double>::infinity();
      double hi = std::numeric_limits<double>::infinity();
      int used = 0;
      for (const auto& [kf_id, view] : seen_by[i]) {
        double a = lo, b = hi;
        // A keyframe whose frustum misses the interval so far is inconsistent with the others
        // (bad pose or visibility list): it is skipped rather than emptying the interval.
        if (!VisibleInterval(lines[i]->line, *view, options.near_m, far_m, samples, &a, &b)) {
          continue;
        }
        lo = a;
        hi = b;
        ++used;
      }
      if (used == 0) continue;
      result.has_estimate[i] = 1;
      result.estimates[i] = lines[i]->line.PointAt(0.5 * (lo + hi));
      const double length = hi - lo;
      result.risk[i] = length <= 2.0 * tau ? 1.0 : 2.0 * tau / length;
    }
  });
  return result;
}

}  // namespace lcv::privacy
