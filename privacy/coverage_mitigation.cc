#include "privacy/coverage_mitigation.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>

#include "privacy/mitigation.h"
#include "slam/camera/camera.h"
#include "slam/util/error.h"

namespace lcv::privacy {
namespace {

// The lines a server keyframe lists, with the image cell of each (-1: no cell).
struct KeyframeCells {
  std::vector<int> cell_count;  // image_grid^2
  int total = 0;
  std::vector<int> cell_required;
  int total_required = 0;
};

int PerCellFloor(const KeyframeCoverageOptions& options) {
  const int cells = options.image_grid * options.image_grid;
  return (options.min_lines_per_keyframe + cells - 1) / cells;
}

// Cell of a world point in a keyframe's image, -1 when it is not imaged inside it.
int ImageCell(const slam::Camera* camera, const slam::ServerKeyframe& kf,
              const Eigen::Vector3d& point, int grid) {
  if (!camera) return -1;
  const auto px = camera->Project(kf.cam_from_world * point);
  if (!px || !camera->InImage(*px)) return -1;
  const int cx = std::min(grid - 1, static_cast<int>(px->x() * grid / camera->cols()));
  const int cy = std::min(grid - 1, static_cast<int>(px->y() * grid / camera->rows()));
  return cy * grid + cx;
}

// Per line id: (keyframe slot, cell) of every keyframe listing it; fills the keyframes' counts.
std::map<slam::Id, std::vector<std::pair<int, int>>> IndexCoverage(
    const slam::Map& map, const std::map<slam::Id, Eigen::Vector3d>& hidden_points,
    const KeyframeCoverageOptions& options, std::vector<KeyframeCells>* keyframes) {
  LCV_CHECK(options.image_grid >= 1 && options.min_lines_per_keyframe >= 0)
      << options.image_grid << " " << options.min_lines_per_keyframe;
  const int cells = options.image_grid * options.image_grid;
  std::map<slam::Id, std::unique_ptr<slam::Camera>> cameras;
  for (const auto& [id, params] : map.cameras) {
    if (!params.Problem()) cameras[id] = slam::MakeCamera(params);
  }
  std::map<slam::Id, std::vector<std::pair<int, int>>> memberships;
  keyframes->clear();
  for (const auto& [kf_id, kf] : map.server_keyframes) {
    KeyframeCells counts;
    counts.cell_count.assign(cells, 0);
    const auto cam = cameras.find(kf.camera_id);
    const slam::Camera* camera = cam == cameras.end() ? nullptr : cam->second.get();
    const int slot = static_cast<int>(keyframes->size());
    for (slam::Id line_id : kf.line_ids) {
      if (!map.lines.count(line_id)) continue;  // dangling id: not a line of this map
      const auto p = hidden_points.find(line_id);
      const int cell =
          p == hidden_points.end() ? -1 : ImageCell(camera, kf, p->second, options.image_grid);
      ++counts.total;
      if (cell >= 0) ++counts.cell_count[cell];
      memberships[line_id].emplace_back(slot, cell);
    }
    keyframes->push_back(std::move(counts));
  }
  const int cell_floor = PerCellFloor(options);
  for (KeyframeCells& k : *keyframes) {
    k.total_required = std::min(k.total, options.min_lines_per_keyframe);
    k.cell_required.resize(cells);
    for (int c = 0; c < cells; ++c) k.cell_required[c] = std::min(k.cell_count[c], cell_floor);
  }
  return memberships;
}

}  // namespace

slam::Map DropWithKeyframeCoverage(const slam::Map& line_cloud,
                                   const std::map<slam::Id, double>& priority,
                                   const std::map<slam::Id, Eigen::Vector3d>& hidden_points,
                                   const CoverageDropOptions& options, CoverageDropReport* report) {
  LCV_CHECK(options.max_lines >= 0) << options.max_lines;
  CoverageDropReport rep;
  rep.num_lines = static_cast<int>(line_cloud.lines.size());
  std::vector<std::pair<double, slam::Id>> ranked;
  for (const auto& [id, p] : priority) {
    if (p > 0.0 && line_cloud.lines.count(id)) ranked.emplace_back(p, id);
  }
  std::sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  rep.num_candidates = static_cast<int>(ranked.size());

  std::vector<KeyframeCells> keyframes;
  const auto memberships =
      IndexCoverage(line_cloud, hidden_points, options.coverage, &keyframes);
  static const std::vector<std::pair<int, int>> kNone;
  auto of = [&](slam::Id id) -> const std::vector<std::pair<int, int>>& {
    const auto it = memberships.find(id);
    return it == memberships.end() ? kNone : it->second;
  };
  auto breaks_coverage = [&](slam::Id id) {
    for (const auto& [slot, cell] : of(id)) {
      const KeyframeCells& k = keyframes[slot];
      if (k.total - 1 < k.total_required) return true;
      if (cell >= 0 && k.cell_count[cell] - 1 < k.cell_required[cell]) return true;
    }
    return false;
  };
  std::set<slam::Id> dropped;
  auto drop = [&](slam::Id id) {
    for (const auto& [slot, cell] : of(id)) {
      --keyframes[slot].total;
      if (cell >= 0) --keyframes[slot].cell_count[cell];
    }
    dropped.insert(id);
  };
  // Direction caps: per cell, how many more lines may go in this call (a cell the reference
  // lacks has no room).
  const int bands = std::max(1, options.direction_bands);
  std::map<int, int> direction_room;
  if (options.direction_reference) {
    const slam::Map& reference = *options.direction_reference;
    const double total = static_cast<double>(reference.lines.size());
    const double after = static_cast<double>(line_cloud.lines.size()) -
                         std::min<double>(options.max_lines, ranked.size());
    const double share = total > 0 ? std::max(0.0, 1.0 - after / total) : 0.0;
    std::map<int, int> reference_count, current_count;
    for (const auto& [id, l] : reference.lines) {
      ++reference_count[DirectionCell(l.line.direction, bands)];
    }
    for (const auto& [id, l] : line_cloud.lines) {
      ++current_count[DirectionCell(l.line.direction, bands)];
    }
    for (const auto& [cell, n] : reference_count) {
      const int cap = static_cast<int>(std::ceil(share * n - 1e-9));
      direction_room[cell] = cap - (n - current_count[cell]);
    }
  }
  auto direction_full = [&](slam::Id id) {
    if (!options.direction_reference) return false;
    const auto it =
        direction_room.find(DirectionCell(line_cloud.lines.at(id).line.direction, bands));
    return it == direction_room.end() || it->second <= 0;
  };
  auto use_direction_room = [&](slam::Id id) {
    if (options.direction_reference) {
      --direction_room[DirectionCell(line_cloud.lines.at(id).line.direction, bands)];
    }
  };
  // Per tier: the unprotected candidates in order, then (break_coverage_when_short) the
  // protected ones in order.
  const auto tier_end =
      std::find_if(ranked.begin(), ranked.end(),
                   [&](const auto& r) { return r.first < options.first_tier_priority; });
  const std::pair<std::size_t, std::size_t> tiers[2] = {
      {0, static_cast<std::size_t>(tier_end - ranked.begin())},
      {static_cast<std::size_t>(tier_end - ranked.begin()), ranked.size()}};
  for (const auto& [begin, end] : tiers) {
    std::vector<slam::Id> protected_ids;
    for (std::size_t k = begin; k < end; ++k) {
      const slam::Id id = ranked[k].second;
      if (static_cast<int>(dropped.size()) >= options.max_lines) break;
      if (direction_full(id)) {
        ++rep.num_held_for_directions;
        continue;
      }
      if (options.guard && breaks_coverage(id)) {
        protected_ids.push_back(id);
        continue;
      }
      drop(id);
      use_direction_room(id);
    }
    rep.num_protected += static_cast<int>(protected_ids.size());
    if (!options.break_coverage_when_short) continue;
    for (slam::Id id : protected_ids) {
      if (static_cast<int>(dropped.size()) >= options.max_lines) break;
      if (direction_full(id)) continue;
      drop(id);
      use_direction_room(id);
      ++rep.num_dropped_protected;
    }
  }
  rep.num_dropped = static_cast<int>(dropped.size());

  slam::Map out = line_cloud;
  for (slam::Id id : dropped) out.lines.erase(id);
  for (auto& [id, kf] : out.server_keyframes) {
    kf.line_ids.erase(std::remove_if(kf.line_ids.begin(), kf.line_ids.end(),
                                     [&](slam::Id l) { return dropped.count(l) > 0; }),
                      kf.line_ids.end());
  }
  if (report) *report = rep;
  return out;
}

KeyframeCoverageStats MeasureKeyframeCoverage(
    const slam::Map& line_cloud, const std::map<slam::Id, Eigen::Vector3d>& hidden_points,
    const KeyframeCoverageOptions& options) {
  std::vector<KeyframeCells> keyframes;
  IndexCoverage(line_cloud, hidden_points, options, &keyframes);
  KeyframeCoverageStats stats;
  stats.keyframes = static_cast<int>(keyframes.size());
  stats.min_lines = keyframes.empty() ? 0 : keyframes.front().total;
  for (const KeyframeCells& k : keyframes) {
    stats.keyframes_with_min_lines += k.total >= options.min_lines_per_keyframe;
    stats.min_lines = std::min(stats.min_lines, k.total);
    for (int n : k.cell_count) stats.occupied_cells += n > 0;
  }
  return stats;
}

std::map<slam::Id, double> RecoveredFirstPriority(const AuditReport& report,
                                                  const std::vector<FailRule>& rules,
                                                  int* excess) {
  std::map<slam::Id, double> priority;
  for (const AttackOutcome& a : report.attacks) {
    for (std::size_t i = 0; i < a.result.size(); ++i) {
      double& p = priority[a.result.line_ids[i]];
      p = std::max(p, a.result.risk[i]);
    }
  }
  if (excess) *excess = 0;
  if (!report.reference_match) return priority;
  std::set<slam::Id> recovered_ids;
  const ReferenceMatch& match = *report.reference_match;
  for (const FailRule& rule : rules) {
    for (const AttackOutcome& a : report.attacks) {
      if (a.result.name != rule.attack || !a.recovery) continue;
      const RecoveryStats& rec = *a.recovery;
      const auto it = std::find(rec.tolerances.begin(), rec.tolerances.end(), rule.tolerance);
      if (it == rec.tolerances.end()) continue;
      const std::size_t k = it - rec.tolerances.begin();
      if (rec.fractions[k] <= rule.max_fraction) continue;  // this rule holds
      const double tolerance_m = rec.tolerances_m[k];
      const std::size_t n = std::min(a.result.size(), match.matched.size());
      int recovered = 0;
      for (std::size_t i = 0; i < n; ++i) {
        if (!match.matched[i] || !a.result.has_estimate[i]) continue;
        if ((a.result.estimates[i] - match.hidden_points[i]).norm() > tolerance_m) continue;
        ++recovered;
        recovered_ids.insert(a.result.line_ids[i]);
      }
      if (excess) {
        const int allowed =
            static_cast<int>(std::floor(rule.max_fraction * rec.num_hidden_points + 1e-9));
        *excess = std::max(*excess, recovered - allowed);
      }
    }
  }
  // Recovered by at least one failing rule: above every line that is not (risk <= 1).
  for (slam::Id id : recovered_ids) priority[id] += kRecoveredPriority;
  return priority;
}

std::map<slam::Id, Eigen::Vector3d> HiddenPointsOf(const AuditReport& report) {
  std::map<slam::Id, Eigen::Vector3d> out;
  if (!report.reference_match || report.attacks.empty()) return out;
  const ReferenceMatch& match = *report.reference_match;
  const LineAttackResult& any = report.attacks.front().result;  // lines in id order
  for (std::size_t i = 0; i < std::min(any.size(), match.matched.size()); ++i) {
    if (match.matched[i]) out[any.line_ids[i]] = match.hidden_points[i];
  }
  return out;
}

}  // namespace lcv::privacy
