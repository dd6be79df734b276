#pragma once
// What an attack on a line cloud produces: per line, possibly an estimate of its hidden point and
// a risk score in [0, 1] (1 = the attacker is confident the point is recovered). Vectors are
// aligned with the map's lines in id order (the iteration order of slam::Map::lines).

#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/util/ids.h"

namespace lcv::privacy {

struct LineAttackResult {
  std::string name;  // "density", "visibility", "duplicate"
  std::vector<slam::Id> line_ids;
  std::vector<Eigen::Vector3d> estimates;    // world frame; meaningful where has_estimate
  std::vector<unsigned char> has_estimate;   // 1 where the attack produced an estimate
  std::vector<double> risk;                  // [0, 1]

  void Resize(std::size_t n) {
    line_ids.resize(n);
    estimates.assign(n, Eigen::Vector3d::Zero());
    has_estimate.assign(n, 0);
    risk.assign(n, 0.0);
  }
  std::size_t size() const { return line_ids.size(); }
};

}  // namespace lcv::privacy
