#include "privacy/mitigation.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <random>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/line_cloud.h"
#include "slam/util/error.h"

namespace lcv::privacy {

int DirectionCell(const Eigen::Vector3d& direction, int bands) {
  // Axial: d and -d are one line direction. Bands equal in z = |d_z| are equal in area.
  const Eigen::Vector3d d = direction.z() < 0 ? Eigen::Vector3d(-direction) : direction;
  const int band = std::min(bands - 1, static_cast<int>(std::floor(std::min(1.0, d.z()) * bands)));
  const int sectors = 2 * bands;
  const double azimuth = std::atan2(d.y(), d.x()) + M_PI;  // [0, 2 pi]
  const int sector = std::min(sectors - 1, static_cast<int>(std::floor(azimuth / (2 * M_PI) * sectors)));
  return band * sectors + sector;
}

slam::Map MitigateRiskiestLines(const slam::Map& line_cloud, const std::map<slam::Id, double>& risk,
                                const std::map<slam::Id, Eigen::Vector3d>& pivots,
                                const MitigationOptions& options, MitigationReport* report) {
  LCV_CHECK(options.fraction >= 0.0 && options.fraction <= 1.0) << options.fraction;
  MitigationReport rep;
  rep.num_lines = static_cast<int>(line_cloud.lines.size());
  const std::size_t budget =
      static_cast<std::size_t>(std::floor(options.fraction * rep.num_lines + 1e-9));
  auto by_risk = [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  };
  // Candidates (risk above min_risk) per direction cell; one cell when not balancing.
  const int bands = std::max(0, options.direction_bands);
  const int num_cells = bands > 0 ? 2 * bands * bands : 1;
  std::vector<std::vector<std::pair<double, slam::Id>>> cells(num_cells);
  std::vector<int> lines_per_cell(num_cells, 0);
  for (const auto& [id, l] : line_cloud.lines) {
    const int cell = bands > 0 ? DirectionCell(l.line.direction, bands) : 0;
    ++lines_per_cell[cell];
    auto it = risk.find(id);
    const double r = it == risk.end() ? 0.0 : it->second;
    if (r > options.min_risk) cells[cell].emplace_back(r, id);
  }
  // Quota per cell proportional to its lines (largest remainders), so the kept directions keep
  // the cells' proportions; a cell short of candidates gives its quota up.
  std::vector<std::size_t> quota(num_cells, 0);
  if (num_cells == 1) {
    quota[0] = budget;
  } else {
    std::vector<std::pair<double, int>> remainders;
    std::size_t assigned = 0;
    for (int c = 0; c < num_cells; ++c) {
      const double exact = options.fraction * lines_per_cell[c];
      quota[c] = static_cast<std::size_t>(std::floor(exact + 1e-9));
      assigned += quota[c];
      remainders.emplace_back(exact - quota[c], c);
    }
    std::sort(remainders.begin(), remainders.end(),
              [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
    for (std::size_t k = 0; assigned < budget && k < remainders.size(); ++k, ++assigned) {
      ++quota[remainders[k].second];
    }
  }
  std::vector<std::pair<double, slam::Id>> ranked;
  for (int c = 0; c < num_cells; ++c) {
    std::sort(cells[c].begin(), cells[c].end(), by_risk);
    cells[c].resize(std::min(cells[c].size(), quota[c]));
    ranked.insert(ranked.end(), cells[c].begin(), cells[c].end());
  }
  std::sort(ranked.begin(), ranked.end(), by_risk);
  std::set<slam::Id> chosen;
  for (const auto& [r, id] : ranked) chosen.insert(id);
  rep.num_changed = static_cast<int>(chosen.size());
  rep.risk_threshold = ranked.empty() ? 0.0 : ranked.back().first;

  slam::Map out = line_cloud;
  if (options.mode == MitigationMode::kDrop) {
    for (slam::Id id : chosen) out.lines.erase(id);
    for (auto& [id, kf] : out.server_keyframes) {
      kf.line_ids.erase(std::remove_if(kf.line_ids.begin(), kf.line_ids.end(),
                                       [&](slam::Id l) { return chosen.count(l) > 0; }),
                        kf.line_ids.end());
    }
  } else {
    const double proxy_floor = mapping::ProxyDistanceFloor(line_cloud);
    std::mt19937_64 rng(options.seed);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    for (slam::Id id : chosen) {  // ascending ids: the directions do not depend on the ranking
      slam::LineLandmark& l = out.lines.at(id);
      const double u = uniform(rng), v = uniform(rng);
      const Eigen::Vector3d d_new = slam::UniformUnitVector(u, v);
      auto p = pivots.find(id);
      const Eigen::Vector3d pivot = p != pivots.end() ? p->second : l.line.anchor;
      rep.num_pivot_given += p != pivots.end();
      l.line.direction = d_new;
      l.line.anchor = pivot - pivot.dot(d_new) * d_new;
      // Omega_L by the publishing rule for the new line (mapping/line_cloud.h, kProxyPoint):
      // from the published line and keyframes alone, whatever rule the input used.
      l.information = mapping::ProxyLineInformation(out, l, proxy_floor);
    }
  }
  if (report) *report = rep;
  return out;
}

std::map<slam::Id, double> CombineRisks(const std::vector<LineAttackResult>& attacks) {
  std::map<slam::Id, double> out;
  for (const auto& a : attacks) {
    for (std::size_t i = 0; i < a.size(); ++i) {
      double& r = out[a.line_ids[i]];
      r = std::max(r, a.risk[i]);
    }
  }
  return out;
}

std::string FormatRiskFile(const LineAttackResult& attack) {
  std::string text = "line_id,risk\n";
  char buf[64];
  for (std::size_t i = 0; i < attack.size(); ++i) {
    std::snprintf(buf, sizeof(buf), "%llu,%.6g\n",
                  static_cast<unsigned long long>(attack.line_ids[i]), attack.risk[i]);
    text += buf;
  }
  return text;
}

std::map<slam::Id, double> ReadRiskFile(const std::string& path) {
  std::istringstream in(mapping::ReadTextFile(path));
  std::string row;
  std::map<slam::Id, double> out;
  int number = 0;
  while (std::getline(in, row)) {
    ++number;
    if (!row.empty() && row.back() == '\r') row.pop_back();
    if (number == 1) {
      if (row != "line_id,risk") {
        throw InputError(path, "line 1: expected the header \"line_id,risk\"");
      }
      continue;
    }
    if (row.empty()) continue;
    const std::string where = "line " + std::to_string(number);
    const auto comma = row.find(',');
    if (comma == std::string::npos) throw InputError(path, where + ": expected \"id,risk\"");
    unsigned long long id = 0;
    double value = 0.0;
    std::size_t used_id = 0, used_risk = 0;
    try {
      id = std::stoull(row.substr(0, comma), &used_id);
      value = std::stod(row.substr(comma + 1), &used_risk);
    } catch (const std::exception&) {
      throw InputError(path, where + ": expected \"id,risk\" numbers, got \"" + row + "\"");
    }
    if (used_id != comma || used_risk != row.size() - comma - 1) {
      throw InputError(path, where + ": trailing characters in \"" + row + "\"");
    }
    if (!(value >= 0.0 && value <= 1.0)) {
      throw InputError(path, where + ": risk " + row.substr(comma + 1) + " outside [0, 1]");
    }
    if (!out.emplace(id, value).second) {
      throw InputError(path, where + ": line id " + std::to_string(id) + " listed twice");
    }
  }
  if (number == 0) throw InputError(path, "empty file, expected the header \"line_id,risk\"");
  return out;
}

std::map<slam::Id, double> ReadRisks(const std::string& path,
                                     const std::optional<std::string>& attack) {
  const std::string bytes = mapping::ReadTextFile(path);
  const auto first = bytes.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || bytes[first] != '{') return ReadRiskFile(path);
  nlohmann::json report;
  try {
    report = nlohmann::json::parse(bytes);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path, std::string("not valid JSON: ") + e.what());
  }
  if (!report.contains("attacks") || !report["attacks"].is_array()) {
    throw InputError(path, "/attacks: missing (not an audit report?)");
  }
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::map<slam::Id, double> risk;
  int used = 0;
  std::string names;
  for (const auto& a : report["attacks"]) {
    const std::string name = a.is_object() && a.contains("name") && a["name"].is_string()
                                 ? a["name"].get<std::string>()
                                 : "?";
    names += " " + name;
    if (attack && name != *attack) continue;
    if (!a.is_object() || !a.contains("risk_file") || !a["risk_file"].is_string()) continue;
    for (const auto& [id, r] : ReadRiskFile((folder / a["risk_file"].get<std::string>()).string())) {
      risk[id] = std::max(risk[id], r);
    }
    ++used;
  }
  if (used == 0) {
    throw InputError(path, attack ? "no attack named '" + *attack +
                                        "' with a risk file (attacks:" + names + ")"
                                  : "no attack with a risk_file");
  }
  return risk;
}

}  // namespace lcv::privacy
