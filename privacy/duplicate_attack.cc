#include "privacy/duplicate_attack.h"

#include <algorithm>
#include <map>

#include "privacy/line_grid.h"
#include "privacy/parallel.h"
#include "privacy/scene_box.h"

namespace lcv::privacy {
namespace {

int SharedCount(const std::vector<slam::Id>& a, const std::vector<slam::Id>& b) {
  int count = 0;
  auto i = a.begin();
  auto j = b.begin();
  while (i != a.end() && j != b.end()) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++count;
      ++i;
      ++j;
    }
  }
  return count;
}

}  // namespace

LineAttackResult RunDuplicateAttack(const slam::Map& map, const DuplicateAttackOptions& options,
                                    std::vector<DuplicatePair>* pairs_out) {
  LineAttackResult result;
  result.name = "duplicate";
  const std::size_t n = map.lines.size();
  result.Resize(n);
  std::vector<const slam::LineLandmark*> landmarks;
  std::vector<slam::Line3d> lines;
  std::map<slam::Id, std::size_t> index_of;
  for (const auto& [id, l] : map.lines) {
    result.line_ids[lines.size()] = id;
    index_of[id] = lines.size();
    lines.push_back(l.line);
    landmarks.push_back(&l);
  }
  if (pairs_out) pairs_out->clear();
  if (n < 2) return result;

  // Visibility of each line, sorted: its own list plus the keyframes listing it.
  std::vector<std::vector<slam::Id>> seen_by(n);
  for (std::size_t i = 0; i < n; ++i) seen_by[i] = landmarks[i]->server_keyframe_ids;
  for (const auto& [id, kf] : map.server_keyframes) {
    for (slam::Id line_id : kf.line_ids) {
      auto it = index_of.find(line_id);
      if (it != index_of.end()) seen_by[it->second].push_back(id);
    }
  }
  for (auto& list : seen_by) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }

  Eigen::AlignedBox3d box = options.box;
  if (box.isEmpty()) {
    std::vector<Eigen::Vector3d> centers;
    for (const auto& [id, kf] : map.server_keyframes) centers.push_back(kf.cam_from_world.Center());
    SceneBoxOptions box_options;
    box_options.num_threads = options.num_threads;
    box = EstimateSceneBox(lines, centers, box_options);
  }
  if (box.isEmpty()) return result;
  const double tol = options.relative_tolerance * box.diagonal().norm();
  const double tol_sq = tol * tol;
  const int workers = ResolveThreadCount(options.num_threads);
  const LineGrid grid(lines, box, ChooseVoxelSize(box, n, options.target_occupancy), workers);

  // Each worker scans a block of voxels; a pair is reported by the voxel holding its meeting
  // point, so it is found once.
  std::vector<std::vector<DuplicatePair>> found(workers);
  ParallelBlocks(grid.num_voxels(), workers, [&](std::size_t begin, std::size_t end, int w) {
    for (std::size_t v = begin; v < end; ++v) {
      const std::uint32_t* first = grid.LinesBegin(v);
      const std::uint32_t* last = grid.LinesEnd(v);
      for (const std::uint32_t* a = first; a != last; ++a) {
        const slam::Line3d& la = lines[*a];
        for (const std::uint32_t* b = a + 1; b != last; ++b) {
          const slam::Line3d& lb = lines[*b];
          const double c = la.direction.dot(lb.direction);
          const double denom = 1.0 - c * c;
          // Parallel lines meet nowhere (or everywhere: a repeated line reveals no point).
          if (denom < 1e-12) continue;
          const Eigen::Vector3d wv = la.anchor - lb.anchor;
          // Distance between the lines: |w . (da x db)| / |da x db|.
          const Eigen::Vector3d normal = la.direction.cross(lb.direction);
          const double num = wv.dot(normal);
          if (num * num > tol_sq * denom) continue;
          const double da = la.direction.dot(wv);
          const double db = lb.direction.dot(wv);
          const double sa = (c * db - da) / denom;
          const double sb = (db - c * da) / denom;
          const Eigen::Vector3d point = 0.5 * (la.PointAt(sa) + lb.PointAt(sb));
          if (!box.contains(point)) continue;
          const Eigen::Vector3i vox = grid.VoxelOf(point);
          if (grid.Index(vox.x(), vox.y(), vox.z()) != v) continue;
          DuplicatePair pair;
          pair.line_a = result.line_ids[*a];
          pair.line_b = result.line_ids[*b];
          pair.point = point;
          pair.distance = std::abs(num) / std::sqrt(denom);
          const auto& desc_a = landmarks[*a]->descriptor;
          const auto& desc_b = landmarks[*b]->descriptor;
          if (desc_a && desc_b) {
            pair.hamming = slam::HammingDistance(*desc_a, *desc_b);
            if (pair.hamming > options.max_hamming) continue;
          } else {
            pair.shared_keyframes = SharedCount(seen_by[*a], seen_by[*b]);
            if (pair.shared_keyframes < options.min_shared_keyframes) continue;
          }
          found[w].push_back(pair);
        }
      }
    }
  });
  std::vector<DuplicatePair> pairs;
  for (auto& f : found) pairs.insert(pairs.end(), f.begin(), f.end());
  std::sort(pairs.begin(), pairs.end(), [](const DuplicatePair& x, const DuplicatePair& y) {
    return std::make_pair(x.line_a, x.line_b) < std::make_pair(y.line_a, y.line_b);
  });
  for (const DuplicatePair& p : pairs) {
    for (slam::Id id : {p.line_a, p.line_b}) {
      const std::size_t i = index_of.at(id);
      result.has_estimate[i] = 1;
      result.estimates[i] = p.point;
      result.risk[i] = 1.0;
    }
  }
  if (pairs_out) *pairs_out = std::move(pairs);
  return result;
}

}  // namespace lcv::privacy
