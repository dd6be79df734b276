#include "mapping/map_merge.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "mapping/line_cloud.h"
#include "slam/optimize/residuals.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using slam::Id;
using slam::Line3d;
using slam::Map;
using slam::Sim3d;

Eigen::Vector3d CanonicalAnchor(const Line3d& line) {
  return line.anchor - line.direction.dot(line.anchor) * line.direction;
}

Line3d TransformLine(const Sim3d& S, const Line3d& line) {
  Line3d out(S * line.anchor, (S.rotation * line.direction).normalized());
  out.anchor = CanonicalAnchor(out);
  return out;
}

// Omega_L of a line mapped by S: lengths scale by s, so information by 1 / s^2, and it turns
// with R. The direction stays in its null space.
Eigen::Matrix3d TransformInformation(const Sim3d& S, const Eigen::Matrix3d& information) {
  const Eigen::Matrix3d R = S.rotation.toRotationMatrix();
  const Eigen::Matrix3d out = R * information * R.transpose() / (S.scale * S.scale);
  return 0.5 * (out + out.transpose());
}

Map AsLineCloud(const Map& map, std::uint64_t seed) {
  if (map.keyframes.empty() && map.points.empty()) return map;
  LineCloudOptions options;
  options.seed = seed;
  return ConvertToLineCloud(map, options);
}

// Union-find over line ids (privacy rule groups).
struct Groups {
  std::map<Id, Id> parent;
  Id Find(Id x) {
    auto it = parent.find(x);
    if (it == parent.end()) return x;
    const Id root = Find(it->second);
    it->second = root;
    return root;
  }
  void Join(Id a, Id b) {
    a = Find(a);
    b = Find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// Pairs (i < j) of descriptors within max_hamming bits, by multi-index hashing: the 256 bits
// cut into 16 chunks of 16 bits; two descriptors are compared when a chunk is identical (always
// so within 15 bits; for 30 bits ~93% of pairs, for 50 bits ~40%, like an LSH of the same
// size). Exact and deterministic, and it avoids FLANN's LSH, whose queries over a 1M-line map
// took minutes. Buckets of more than kMaxBucket descriptors (a descriptor repeated many times)
// are compared only with their first kMaxBucket members.
std::vector<std::pair<int, int>> DescriptorPairs(const std::vector<slam::OrbDescriptor>& d,
                                                 int max_hamming) {
  constexpr std::size_t kMaxBucket = 256;
  std::vector<std::pair<int, int>> pairs;
  std::vector<std::pair<std::uint16_t, int>> keys(d.size());
  for (int chunk = 0; chunk < 16; ++chunk) {
    for (std::size_t i = 0; i < d.size(); ++i) {
      keys[i] = {static_cast<std::uint16_t>(d[i][2 * chunk] | (d[i][2 * chunk + 1] << 8)),
                 static_cast<int>(i)};
    }
    std::sort(keys.begin(), keys.end());
    for (std::size_t begin = 0; begin < keys.size();) {
      std::size_t end = begin + 1;
      while (end < keys.size() && keys[end].first == keys[begin].first) ++end;
      const std::size_t last = std::min(end, begin + kMaxBucket);
      for (std::size_t x = begin; x < last; ++x) {
        for (std::size_t y = x + 1; y < last; ++y) {
          const int a = keys[x].second, b = keys[y].second;
          if (slam::HammingDistance(d[a], d[b]) <= max_hamming) {
            pairs.emplace_back(std::min(a, b), std::max(a, b));
          }
        }
      }
      begin = end;
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

}  // namespace

struct MapMerger::Registration {
  std::vector<Line3d> base_lines;
  std::vector<Id> base_ids;
  std::vector<int> index_lines;  // descriptor index position -> base_lines index
  std::unique_ptr<LineDescriptorIndex> index;
};

std::string MapMergeOptions::Problem() const {
  if (const std::string p = registration.Problem(); !p.empty()) return "registration: " + p;
  if (const std::string p = optimization.Problem(); !p.empty()) return "optimization: " + p;
  if (duplicate_max_hamming < 0 || duplicate_max_hamming > 256)
    return "duplicate_max_hamming must be in [0, 256]";
  if (!(duplicate_sigma_factor >= 0.0)) return "duplicate_sigma_factor must be >= 0";
  if (!(duplicate_min_relative >= 0.0 && duplicate_max_relative >= duplicate_min_relative))
    return "need 0 <= duplicate_min_relative <= duplicate_max_relative";
  return "";
}

double CameraExtent(const Map& map) {
  if (map.server_keyframes.size() < 2) return 1.0;
  Eigen::AlignedBox3d box;
  for (const auto& [id, kf] : map.server_keyframes) box.extend(kf.cam_from_world.Center());
  const double diagonal = box.diagonal().norm();
  return diagonal > 1e-9 ? diagonal : 1.0;
}

MapMerger::MapMerger(const Map& base, const MapMergeOptions& options) : options_(options) {
  const std::string problem = options.Problem();
  LCV_CHECK(problem.empty()) << problem;
  map_ = AsLineCloud(base, options.seed);
  for (const auto& [id, line] : map_.lines) base_lines_.insert(id);
  for (const auto& [id, kf] : map_.server_keyframes) base_server_keyframes_.insert(id);
  scene_scale_ = CameraExtent(map_);
  next_id_ = map_.NextFreeId();
  virtual_observations_ = VirtualObservationsOf(map_);
}

MapMerger::~MapMerger() = default;

void MapMerger::AddRejected(const std::string& name, const std::string& reason) {
  UploadMergeResult result;
  result.name = name;
  result.reason = reason;
  results_.push_back(result);
}

UploadMergeResult MapMerger::AddUpload(const Map& upload_in, const std::string& name) {
  UploadMergeResult result;
  result.name = name;
  const Map upload = AsLineCloud(upload_in, options_.seed + results_.size() + 1);
  if (upload.lines.empty() || upload.server_keyframes.empty()) {
    result.reason = "no lines or no server keyframes";
    results_.push_back(result);
    return result;
  }
  // Same frame? Upload lines with base ids that are the same line.
  std::map<Id, Id> same_ids;
  int shared = 0;
  for (const auto& [id, line] : upload.lines) {
    const auto base = map_.lines.find(id);
    if (base == map_.lines.end() || !base_lines_.count(id)) continue;
    ++shared;
    bool same = false;
    if (line.descriptor && base->second.descriptor) {
      same = slam::HammingDistance(*line.descriptor, *base->second.descriptor) <= 10;
    } else {
      same = std::abs(line.line.direction.dot(base->second.line.direction)) >
             std::cos(M_PI / 180.0);
    }
    if (same) same_ids[id] = id;
  }
  const bool looks_same = same_ids.size() >= 6 && 2 * same_ids.size() >= static_cast<size_t>(shared);
  const bool same_frame = options_.frame == UploadFrame::kSame ||
                          (options_.frame == UploadFrame::kAuto && looks_same);
  if (same_frame) {
    result.frame = "same";
    result.accepted = true;
    result.reason = std::to_string(same_ids.size()) + " lines refer to base lines";
    AddLines(upload, std::nullopt, same_ids, static_cast<int>(results_.size()), &result);
    results_.push_back(result);
    return result;
  }

  result.frame = "independent";
  if (!registration_) {
    registration_ = std::make_unique<Registration>();
    std::vector<slam::OrbDescriptor> descriptors;
    for (Id id : base_lines_) {
      const slam::LineLandmark& line = map_.lines.at(id);
      if (line.descriptor) {
        registration_->index_lines.push_back(static_cast<int>(registration_->base_lines.size()));
        descriptors.push_back(*line.descriptor);
      }
      registration_->base_lines.push_back(line.line);
      registration_->base_ids.push_back(id);
    }
    registration_->index = std::make_unique<LineDescriptorIndex>(descriptors);
  }
  std::vector<Line3d> upload_lines;
  std::vector<std::optional<slam::OrbDescriptor>> upload_descriptors;
  std::vector<Id> upload_ids;
  for (const auto& [id, line] : upload.lines) {
    upload_lines.push_back(line.line);
    upload_descriptors.push_back(line.descriptor);
    upload_ids.push_back(id);
  }
  LineRegistrationOptions registration = options_.registration;
  registration.seed += results_.size();
  const LineRegistrationResult reg = RegisterLineCloud(
      registration_->base_lines, *registration_->index, registration_->index_lines, upload_lines,
      upload_descriptors, scene_scale_, registration);
  result.registration_candidates = reg.num_candidates;
  result.registration_inliers = reg.num_inliers;
  result.reason = reg.reason;
  if (!reg.success) {
    result.reason = "registration failed: " + reg.reason;
    results_.push_back(result);
    return result;
  }
  result.accepted = true;
  result.base_from_upload = reg.base_from_upload;
  std::map<Id, Id> merged;
  for (const LineCorrespondence& c : reg.inliers) {
    merged[upload_ids[c.upload]] = registration_->base_ids[c.base];
  }
  AddLines(upload, reg.base_from_upload, merged, static_cast<int>(results_.size()), &result);
  results_.push_back(result);
  return result;
}

void MapMerger::AddLines(const Map& upload, const std::optional<Sim3d>& base_from_upload,
                         const std::map<Id, Id>& merged_ids, int upload_number,
                         UploadMergeResult* result) {
  const Sim3d S = base_from_upload.value_or(Sim3d());
  std::map<Id, Id> camera_ids, line_ids;
  for (const auto& [id, camera] : upload.cameras) {
    camera_ids[id] = next_id_;
    map_.cameras[next_id_] = camera;
    ++next_id_;
  }
  // Lines: merged into base lines, or added with fresh ids.
  std::map<Id, Line3d> upload_geometry;  // in the base frame, for the virtual observations
  for (const auto& [id, line] : upload.lines) {
    const Line3d geometry = base_from_upload ? TransformLine(S, line.line) : line.line;
    upload_geometry[id] = geometry;
    const auto merged = merged_ids.find(id);
    if (merged != merged_ids.end()) {
      line_ids[id] = merged->second;
      ++result->lines_merged;
      continue;
    }
    slam::LineLandmark added;
    added.id = next_id_++;
    added.line = geometry;
    added.line.anchor = CanonicalAnchor(geometry);
    added.information =
        base_from_upload ? TransformInformation(S, line.information) : line.information;
    added.descriptor = line.descriptor;
    line_ids[id] = added.id;
    line_origin_[added.id] = upload_number;
    map_.lines.emplace(added.id, std::move(added));
    ++result->lines_added;
  }
  // Upload lines merged into a different line (another direction through the same point) keep
  // their own geometry as an observed copy for the optimization (merge_optimization.h).
  std::map<Id, int> copy_of;
  for (const auto& [id, target] : merged_ids) {
    const auto line = upload.lines.find(id);
    if (line == upload.lines.end()) continue;
    const Line3d& geometry = upload_geometry.at(id);
    const Line3d& kept = map_.lines.at(target).line;
    if (std::abs(geometry.direction.dot(kept.direction)) > 1.0 - 1e-12 &&
        kept.Distance(geometry.anchor) < 1e-9 * (1.0 + geometry.anchor.norm())) {
      continue;  // the same line
    }
    copy_of[id] = static_cast<int>(copies_.size());
    copies_.push_back({target, geometry,
                       base_from_upload ? TransformInformation(S, line->second.information)
                                        : line->second.information});
  }
  // Server keyframes: fresh ids, poses in the base frame, visibility both ways.
  for (const auto& [id, kf] : upload.server_keyframes) {
    slam::ServerKeyframe joined = kf;
    joined.id = next_id_++;
    const auto camera = camera_ids.find(kf.camera_id);
    joined.camera_id = camera != camera_ids.end() ? camera->second : kf.camera_id;
    if (base_from_upload) joined.cam_from_world = slam::TransformPose(S, kf.cam_from_world);
    joined.line_ids.clear();
    for (Id line_id : kf.line_ids) {
      const auto mapped = line_ids.find(line_id);
      if (mapped == line_ids.end()) continue;
      joined.line_ids.push_back(mapped->second);
      const Eigen::Vector3d normal =
          slam::LinePlaneNormal(joined.cam_from_world, upload_geometry.at(line_id));
      if (normal.squaredNorm() > 0.5) {
        const auto copy = copy_of.find(line_id);
        virtual_observations_.push_back(
            {joined.id, mapped->second, normal, copy == copy_of.end() ? -1 : copy->second});
      }
      std::vector<Id>& seen_by = map_.lines.at(mapped->second).server_keyframe_ids;
      seen_by.insert(std::upper_bound(seen_by.begin(), seen_by.end(), joined.id), joined.id);
    }
    std::sort(joined.line_ids.begin(), joined.line_ids.end());
    joined.line_ids.erase(std::unique(joined.line_ids.begin(), joined.line_ids.end()),
                          joined.line_ids.end());
    map_.server_keyframes.emplace(joined.id, std::move(joined));
    ++result->server_keyframes_added;
  }
  // A line seen twice by one keyframe (two upload lines merged into one base line): once.
  for (auto& [id, line] : map_.lines) {
    auto& ids = line.server_keyframe_ids;
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  }
}

int MapMerger::ApplyPrivacyRule(MapMergeReport* report) {
  // Lines with descriptors, indexed.
  std::vector<Id> ids;
  std::vector<slam::OrbDescriptor> descriptors;
  for (const auto& [id, line] : map_.lines) {
    if (!line.descriptor) continue;
    ids.push_back(id);
    descriptors.push_back(*line.descriptor);
  }
  if (ids.size() < 2) return 0;
  const double min_distance = options_.duplicate_min_relative * scene_scale_;
  const double max_distance = options_.duplicate_max_relative * scene_scale_;
  // Visibility consistency without a shared keyframe: the point where the lines meet is in
  // front of a server keyframe that sees each of them.
  auto in_front_of_a_viewer = [&](const Eigen::Vector3d& meeting_point,
                                  const slam::LineLandmark& line) {
    for (Id kf_id : line.server_keyframe_ids) {
      const slam::ServerKeyframe& kf = map_.server_keyframes.at(kf_id);
      if ((kf.cam_from_world * meeting_point).z() > 0.0) return true;
    }
    return false;
  };
  Groups groups;
  const std::vector<std::pair<int, int>> pairs =
      DescriptorPairs(descriptors, options_.duplicate_max_hamming);
  for (const auto& [i, j] : pairs) {
    const slam::LineLandmark& a = map_.lines.at(ids[i]);
    {
      const slam::LineLandmark& b = map_.lines.at(ids[j]);
      const auto closest = slam::ClosestPointsBetweenLines(a.line, b.line, 1e-6);
      const double distance = closest ? closest->distance : a.line.Distance(b.line.anchor);
      double tolerance = options_.duplicate_sigma_factor *
                         std::hypot(LinePerpendicularSigma(a.information),
                                    LinePerpendicularSigma(b.information));
      tolerance = std::clamp(std::isfinite(tolerance) ? tolerance : max_distance, min_distance,
                             max_distance);
      if (distance > tolerance) continue;
      std::vector<Id> common;
      std::set_intersection(a.server_keyframe_ids.begin(), a.server_keyframe_ids.end(),
                            b.server_keyframe_ids.begin(), b.server_keyframe_ids.end(),
                            std::back_inserter(common));
      const Eigen::Vector3d meeting_point =
          closest ? 0.5 * (a.line.PointAt(closest->s_a) + b.line.PointAt(closest->s_b))
                  : a.line.anchor;
      if (common.empty() &&
          !(in_front_of_a_viewer(meeting_point, a) && in_front_of_a_viewer(meeting_point, b))) {
        continue;
      }
      groups.Join(ids[i], ids[j]);
    }
  }
  // Keep a base line of each group, else the smallest id.
  std::map<Id, Id> keep;  // root -> kept id
  for (const auto& [member, parent] : groups.parent) {
    (void)parent;
    for (Id id : {member, groups.Find(member)}) {
      const Id root = groups.Find(id);
      auto it = keep.find(root);
      const bool is_base = base_lines_.count(id) > 0;
      if (it == keep.end()) {
        keep[root] = id;
      } else if (is_base && !base_lines_.count(it->second)) {
        it->second = id;
      } else if (is_base == (base_lines_.count(it->second) > 0) && id < it->second) {
        it->second = id;
      }
    }
  }
  std::map<Id, Id> replaced;  // dropped -> kept
  for (const auto& [member, parent] : groups.parent) {
    (void)parent;
    for (Id id : {member, groups.Find(member)}) {
      const Id kept = keep.at(groups.Find(id));
      if (id != kept) replaced[id] = kept;
    }
  }
  std::map<Id, std::pair<Line3d, Eigen::Matrix3d>> dropped_geometry;
  for (const auto& [dropped, kept] : replaced) {
    dropped_geometry[dropped] = {map_.lines.at(dropped).line, map_.lines.at(dropped).information};
    slam::LineLandmark& kept_line = map_.lines.at(kept);
    for (Id kf_id : map_.lines.at(dropped).server_keyframe_ids) {
      kept_line.server_keyframe_ids.push_back(kf_id);
      auto& line_ids = map_.server_keyframes.at(kf_id).line_ids;
      std::replace(line_ids.begin(), line_ids.end(), dropped, kept);
      std::sort(line_ids.begin(), line_ids.end());
      line_ids.erase(std::unique(line_ids.begin(), line_ids.end()), line_ids.end());
    }
    std::sort(kept_line.server_keyframe_ids.begin(), kept_line.server_keyframe_ids.end());
    kept_line.server_keyframe_ids.erase(
        std::unique(kept_line.server_keyframe_ids.begin(), kept_line.server_keyframe_ids.end()),
        kept_line.server_keyframe_ids.end());
    map_.lines.erase(dropped);
    const auto origin = line_origin_.find(dropped);
    if (origin != line_origin_.end()) ++results_[origin->second].lines_dropped;
    if (base_lines_.count(dropped)) base_lines_.erase(dropped);
  }
  // Observations of a dropped line were of ITS geometry: it lives on as an observed copy.
  std::map<Id, int> copy_of_dropped;
  for (VirtualObservationRecord& v : virtual_observations_) {
    const auto it = replaced.find(v.line_id);
    if (it == replaced.end()) continue;
    if (v.copy < 0) {
      auto copy = copy_of_dropped.find(v.line_id);
      if (copy == copy_of_dropped.end()) {
        copy = copy_of_dropped.emplace(v.line_id, static_cast<int>(copies_.size())).first;
        copies_.push_back({it->second, dropped_geometry.at(v.line_id).first,
                           dropped_geometry.at(v.line_id).second});
      }
      v.copy = copy->second;
    }
    v.line_id = it->second;
  }
  for (ObservedLineCopy& copy : copies_) {
    const auto it = replaced.find(copy.line_id);
    if (it != replaced.end()) copy.line_id = it->second;
  }
  report->duplicate_groups += static_cast<int>(keep.size());
  report->lines_dropped += static_cast<int>(replaced.size());
  return static_cast<int>(replaced.size());
}

Map MapMerger::Finish(MapMergeReport* report) {
  const auto start = std::chrono::steady_clock::now();
  ApplyPrivacyRule(report);
  if (options_.optimize) {
    report->optimization =
        OptimizeLineCloud(options_.optimization, virtual_observations_, copies_,
                          base_server_keyframes_, base_lines_, &map_);
    ApplyPrivacyRule(report);
  }
  // Anchors by the line-cloud rule after any move, and Omega_L by the publishing rule for the
  // merged map: an upload published with eq. 1 of its points' covariances (or by an older build)
  // must not pass its leaky Omega_L on (mapping/line_cloud.h, LineInformationRule).
  for (auto& [id, line] : map_.lines) line.line.anchor = CanonicalAnchor(line.line);
  SetProxyInformation(&map_);
  report->uploads = results_;
  report->seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return std::move(map_);
}

}  // namespace lcv::mapping
