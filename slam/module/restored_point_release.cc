#include "slam/module/restored_point_release.h"

#include <cmath>

namespace lcv::slam {

int ReleaseRestoredPointsOffTheirLines(const std::vector<Id>& landmark_ids,
                                       const Eigen::Vector3d& viewpoint, double max_angle_rad,
                                       SlamMap* map) {
  if (!(max_angle_rad > 0.0)) return 0;
  const double tan_max = std::tan(max_angle_rad);
  int released = 0;
  for (const Id id : landmark_ids) {
    const SlamLandmark* landmark = map->FindLandmark(id);
    if (landmark == nullptr || !landmark->IsRestored() || landmark->NumObservations() < 2) continue;
    SlamLine* line = map->FindLine(landmark->line_id);
    if (line == nullptr) continue;
    const Eigen::Vector3d& x = landmark->position_in_world;
    const double depth = (x - viewpoint).norm();
    if (!(line->reference_line.Distance(x) > tan_max * depth)) continue;
    map->ReleaseFromLine(id);
    line->MoveTo(line->reference_line);  // Omega_L turns back with it
    ++released;
  }
  return released;
}

}  // namespace lcv::slam
