#include "mapping/line_registration.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/flann.hpp>

#include "slam/geometry/so3.h"
#include "slam/solve/ransac.h"

namespace lcv::mapping {
namespace {

using slam::Line3d;
using slam::Sim3d;
using Vector7d = Eigen::Matrix<double, 7, 1>;
using Matrix7d = Eigen::Matrix<double, 7, 7>;

// (1) of the header and its gradient wrt [omega (left perturbation of R); s; t].
double ReciprocalResidual(const Sim3d& S, const Line3d& up, const Line3d& base,
                          Eigen::Matrix<double, 1, 7>* J) {
  const Eigen::Vector3d m_u = up.anchor.cross(up.direction);
  const Eigen::Vector3d m_b = base.anchor.cross(base.direction);
  const Eigen::Vector3d u = S.rotation * m_u;
  const Eigen::Vector3d w = S.rotation * up.direction;
  const Eigen::Vector3d& d_b = base.direction;
  const Eigen::Vector3d& t = S.translation;
  const Eigen::Vector3d w_x_db = w.cross(d_b);
  if (J) {
    // d(R v) = omega x R v. s d_b.(omega x u) = omega.(s u x d_b);
    // t.((omega x w) x d_b) = omega.((t.w) d_b - (w.d_b) t); (omega x w).m_b = omega.(w x m_b).
    J->segment<3>(0) = (S.scale * u.cross(d_b) + t.dot(w) * d_b - w.dot(d_b) * t +
                        w.cross(m_b)).transpose();
    (*J)(3) = d_b.dot(u);
    J->segment<3>(4) = w_x_db.transpose();
  }
  return S.scale * d_b.dot(u) + t.dot(w_x_db) + w.dot(m_b);
}

void ApplyStep(const Vector7d& step, Sim3d* S) {
  S->rotation = (slam::ExpSO3(step.head<3>()) * S->rotation).normalized();
  S->scale += step(3);
  S->translation += step.tail<3>();
}

// Levenberg-Marquardt on sum_i (weight_i r_i)^2. Returns the final cost.
double LevenbergMarquardt(const Line3d* up, const Line3d* base, int count, const double* weights,
                          int max_iterations, Sim3d* S) {
  auto cost_of = [&](const Sim3d& model) {
    double c = 0.0;
    for (int i = 0; i < count; ++i) {
      const double r = (weights ? weights[i] : 1.0) * ReciprocalResidual(model, up[i], base[i], nullptr);
      c += r * r;
    }
    return c;
  };
  double cost = cost_of(*S);
  double lambda = 1e-4;
  for (int it = 0; it < max_iterations && cost > 1e-24; ++it) {
    Matrix7d H = Matrix7d::Zero();
    Vector7d g = Vector7d::Zero();
    Eigen::Matrix<double, 1, 7> J;
    for (int i = 0; i < count; ++i) {
      const double w = weights ? weights[i] : 1.0;
      const double r = w * ReciprocalResidual(*S, up[i], base[i], &J);
      J *= w;
      H.noalias() += J.transpose() * J;
      g.noalias() += J.transpose() * r;
    }
    bool improved = false;
    for (int attempt = 0; attempt < 6 && !improved; ++attempt) {
      Matrix7d damped = H;
      damped.diagonal() += lambda * (H.diagonal().array() + 1e-12).matrix();
      const Vector7d step = damped.ldlt().solve(-g);
      if (!step.allFinite()) return cost;
      Sim3d candidate = *S;
      ApplyStep(step, &candidate);
      const double new_cost = cost_of(candidate);
      if (new_cost < cost) {
        const bool tiny = step.norm() < 1e-12;
        *S = candidate;
        cost = new_cost;
        lambda = std::max(1e-9, lambda * 0.1);
        improved = true;
        if (tiny) return cost;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return cost;
}

// The 24 rotations of the cube group (signed permutation matrices with det +1).
const std::vector<Eigen::Quaterniond>& CubeRotations() {
  static const std::vector<Eigen::Quaterniond> rotations = [] {
    std::vector<Eigen::Quaterniond> out;
    int perm[3] = {0, 1, 2};
    do {
      for (int signs = 0; signs < 8; ++signs) {
        Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
        for (int r = 0; r < 3; ++r) R(r, perm[r]) = (signs >> r & 1) ? -1.0 : 1.0;
        if (R.determinant() > 0) out.emplace_back(R);
      }
    } while (std::next_permutation(perm, perm + 3));
    return out;
  }();
  return rotations;
}

// Normalization x -> (x - centre) / scale of one side.
struct Normalization {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double scale = 1.0;
  Line3d Apply(const Line3d& l) const { return Line3d((l.anchor - centre) / scale, l.direction); }
  Sim3d ToSim3() const {  // normalized_from_original
    return Sim3d(1.0 / scale, Eigen::Quaterniond::Identity(), -centre / scale);
  }
};

Normalization NormalizationOf(const Line3d* lines, int count) {
  Normalization n;
  if (count <= 0) return n;
  for (int i = 0; i < count; ++i) n.centre += lines[i].anchor;
  n.centre /= count;
  double sq = 0.0;
  for (int i = 0; i < count; ++i) sq += (lines[i].anchor - n.centre).squaredNorm();
  n.scale = std::sqrt(sq / count);
  if (!(n.scale > 1e-12)) n.scale = 1.0;
  return n;
}

class LineLineSim3Estimator {
 public:
  using Model = Sim3d;  // base_from_upload
  static constexpr int kMinNumSamples = 7;
  LineLineSim3Estimator(const std::vector<Line3d>& up, const std::vector<Line3d>& base,
                        double huber)
      : up_(up), base_(base), huber_(huber) {}
  int NumData() const { return static_cast<int>(up_.size()); }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const {
    std::vector<Line3d> u, b;
    for (int i : sample) {
      u.push_back(up_[i]);
      b.push_back(base_[i]);
    }
    SolveSim3LineLine(u.data(), b.data(), static_cast<int>(u.size()), models);
  }
  void Residuals(const Model& S, std::vector<double>* squared) const {
    squared->resize(up_.size());
    for (size_t i = 0; i < up_.size(); ++i) {
      const double d = LineLineDistance(S, up_[i], base_[i]);
      (*squared)[i] = d * d;
    }
  }
  bool Refine(const std::vector<int>& inliers, Model* S) const {
    std::vector<Line3d> u, b;
    for (int i : inliers) {
      u.push_back(up_[i]);
      b.push_back(base_[i]);
    }
    return RefineSim3LineLine(u.data(), b.data(), static_cast<int>(u.size()), huber_, S);
  }

 private:
  const std::vector<Line3d>& up_;
  const std::vector<Line3d>& base_;
  double huber_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------

struct LineDescriptorIndex::Impl {
  cv::Mat data;
  std::unique_ptr<cv::flann::Index> index;
};

LineDescriptorIndex::LineDescriptorIndex(const std::vector<slam::OrbDescriptor>& descriptors,
                                         int multi_probe_level)
    : descriptors_(descriptors), impl_(std::make_unique<Impl>()) {
  if (descriptors_.empty()) return;
  impl_->data = cv::Mat(static_cast<int>(descriptors_.size()), 32, CV_8U,
                        const_cast<std::uint8_t*>(descriptors_.front().data()));
  // 12 tables of 20-bit keys: FLANN's guidance for ORB-like descriptors.
  impl_->index = std::make_unique<cv::flann::Index>(
      impl_->data, cv::flann::LshIndexParams(12, 20, multi_probe_level),
      cvflann::FLANN_DIST_HAMMING);
}

LineDescriptorIndex::~LineDescriptorIndex() = default;

void LineDescriptorIndex::Query(const slam::OrbDescriptor& query, int k, int max_hamming,
                                std::vector<std::pair<int, int>>* neighbours) const {
  neighbours->clear();
  if (!impl_->index || k <= 0) return;
  k = std::min(k, size());
  cv::Mat q(1, 32, CV_8U, const_cast<std::uint8_t*>(query.data()));
  cv::Mat indices(1, k, CV_32S), distances(1, k, CV_32S);
  impl_->index->knnSearch(q, indices, distances, k, cv::flann::SearchParams(64));
  for (int j = 0; j < k; ++j) {
    const int index = indices.at<int>(0, j);
    if (index < 0 || index >= size()) continue;
    // Recomputed: FLANN's distance type for Hamming varies between versions.
    const int distance = slam::HammingDistance(query, descriptors_[index]);
    if (distance <= max_hamming) neighbours->emplace_back(index, distance);
  }
  std::sort(neighbours->begin(), neighbours->end(),
            [](const auto& a, const auto& b) { return a.second < b.second; });
}

void LineDescriptorIndex::QueryIndexed(
    int first, int count, int k, int max_hamming,
    std::vector<std::vector<std::pair<int, int>>>* neighbours) const {
  neighbours->assign(count, {});
  if (!impl_->index || k <= 0 || count <= 0) return;
  k = std::min(k, size());
  const cv::Mat queries = impl_->data.rowRange(first, first + count);
  cv::Mat indices(count, k, CV_32S), distances(count, k, CV_32S);
  impl_->index->knnSearch(queries, indices, distances, k, cv::flann::SearchParams(64));
  for (int q = 0; q < count; ++q) {
    auto& out = (*neighbours)[q];
    for (int j = 0; j < k; ++j) {
      const int index = indices.at<int>(q, j);
      if (index < 0 || index >= size()) continue;
      const int distance = slam::HammingDistance(descriptors_[first + q], descriptors_[index]);
      if (distance <= max_hamming) out.emplace_back(index, distance);
    }
  }
}

std::string LineRegistrationOptions::Problem() const {
  std::ostringstream out;
  if (max_hamming < 0 || max_hamming > 256) out << "max_hamming must be in [0, 256]";
  else if (candidates_per_line < 1) out << "candidates_per_line must be >= 1";
  else if (!(inlier_distance > 0.0) && !(inlier_distance_relative > 0.0))
    out << "inlier_distance or inlier_distance_relative must be > 0";
  else if (max_trials < 1) out << "max_trials must be >= 1";
  else if (min_inliers < 7) out << "min_inliers must be >= 7";
  else if (!(min_scale > 0.0 && max_scale > min_scale)) out << "need 0 < min_scale < max_scale";
  return out.str();
}

double LineLineDistance(const Sim3d& S, const Line3d& upload_line, const Line3d& base_line) {
  const Eigen::Vector3d p = S * upload_line.anchor;
  const Eigen::Vector3d d = S.rotation * upload_line.direction;
  const Eigen::Vector3d cross = d.cross(base_line.direction);
  const double sin_angle = cross.norm();
  const Eigen::Vector3d between = p - base_line.anchor;
  if (sin_angle < 1e-9) return between.cross(base_line.direction).norm();
  return std::abs(between.dot(cross)) / sin_angle;
}

int SolveSim3LineLine(const Line3d* upload_lines, const Line3d* base_lines, int count,
                      std::vector<Sim3d>* solutions) {
  solutions->clear();
  if (count < 7) return 0;
  const Normalization nu = NormalizationOf(upload_lines, count);
  const Normalization nb = NormalizationOf(base_lines, count);
  std::vector<Line3d> up(count), base(count);
  for (int i = 0; i < count; ++i) {
    up[i] = nu.Apply(upload_lines[i]);
    base[i] = nb.Apply(base_lines[i]);
  }
  struct Found {
    Sim3d model;
    double cost;
  };
  std::vector<Found> found;
  Eigen::MatrixXd A(count, 4);
  Eigen::VectorXd c(count);
  for (const Eigen::Quaterniond& start : CubeRotations()) {
    // (s, t) from (1) for this rotation.
    for (int i = 0; i < count; ++i) {
      const Eigen::Vector3d u = start * up[i].anchor.cross(up[i].direction);
      const Eigen::Vector3d w = start * up[i].direction;
      A(i, 0) = base[i].direction.dot(u);
      A.block<1, 3>(i, 1) = w.cross(base[i].direction).transpose();
      c(i) = -w.dot(base[i].anchor.cross(base[i].direction));
    }
    const Eigen::Vector4d x = A.colPivHouseholderQr().solve(c);
    if (!x.allFinite()) continue;
    Sim3d S(x(0), start, x.tail<3>());
    const double cost = LevenbergMarquardt(up.data(), base.data(), count, nullptr, 30, &S);
    if (!(cost < 1e-8 * count) || !(S.scale > 1e-6) || !std::isfinite(S.scale)) continue;
    bool duplicate = false;
    for (const Found& f : found) {
      duplicate |= slam::AngularDistance(f.model.rotation, S.rotation) < 1e-4 &&
                   std::abs(f.model.scale - S.scale) < 1e-4 * S.scale;
    }
    if (!duplicate) found.push_back({S, cost});
  }
  std::sort(found.begin(), found.end(),
            [](const Found& a, const Found& b) { return a.cost < b.cost; });
  // base = nb^-1 * S * nu (normalized frames on both sides).
  for (size_t i = 0; i < found.size() && i < 4; ++i) {
    solutions->push_back(nb.ToSim3().Inverse() * found[i].model * nu.ToSim3());
  }
  return static_cast<int>(solutions->size());
}

bool RefineSim3LineLine(const Line3d* upload_lines, const Line3d* base_lines, int count,
                        double huber_distance, Sim3d* base_from_upload) {
  if (count < 7) return false;
  // Refined in the normalized frames (conditioning), mapped back at the end.
  const Normalization nu = NormalizationOf(upload_lines, count);
  const Normalization nb = NormalizationOf(base_lines, count);
  std::vector<Line3d> up(count), base(count);
  for (int i = 0; i < count; ++i) {
    up[i] = nu.Apply(upload_lines[i]);
    base[i] = nb.Apply(base_lines[i]);
  }
  Sim3d S = nb.ToSim3() * *base_from_upload * nu.ToSim3().Inverse();
  const double huber = huber_distance / nb.scale;
  std::vector<double> weights(count);
  for (int round = 0; round < 5; ++round) {
    // IRLS: residual (1) divided by the sine of the angle between the lines is their distance;
    // Huber weights on that distance.
    for (int i = 0; i < count; ++i) {
      const Eigen::Vector3d d = S.rotation * up[i].direction;
      const double sin_angle = std::max(0.05, d.cross(base[i].direction).norm());
      const double distance = LineLineDistance(S, up[i], base[i]);
      const double huber_weight = distance <= huber ? 1.0 : std::sqrt(huber / distance);
      weights[i] = huber_weight / sin_angle;
    }
    LevenbergMarquardt(up.data(), base.data(), count, weights.data(), 20, &S);
  }
  if (!(S.scale > 0.0) || !S.translation.allFinite()) return false;
  *base_from_upload = nb.ToSim3().Inverse() * S * nu.ToSim3();
  return true;
}

LineRegistrationResult RegisterLineCloud(
    const std::vector<Line3d>& base_lines, const LineDescriptorIndex& base_index,
    const std::vector<int>& base_index_lines, const std::vector<Line3d>& upload_lines,
    const std::vector<std::optional<slam::OrbDescriptor>>& upload_descriptors, double scene_scale,
    const LineRegistrationOptions& options) {
  LineRegistrationResult result;
  result.inlier_distance = options.inlier_distance > 0.0
                               ? options.inlier_distance
                               : options.inlier_distance_relative * scene_scale;
  // Candidates.
  std::vector<LineCorrespondence> candidates;
  std::vector<std::pair<int, int>> neighbours;
  for (size_t i = 0; i < upload_lines.size(); ++i) {
    if (!upload_descriptors[i]) continue;
    base_index.Query(*upload_descriptors[i], options.candidates_per_line, options.max_hamming,
                     &neighbours);
    for (const auto& [index, distance] : neighbours) {
      candidates.push_back({static_cast<int>(i), base_index_lines[index], distance});
    }
  }
  result.num_candidates = static_cast<int>(candidates.size());
  if (result.num_candidates < options.min_inliers) {
    result.reason = "too few descriptor matches: " + std::to_string(result.num_candidates) +
                    " (need " + std::to_string(options.min_inliers) + ")";
    return result;
  }
  std::vector<Line3d> up(candidates.size()), base(candidates.size());
  for (size_t i = 0; i < candidates.size(); ++i) {
    up[i] = upload_lines[candidates[i].upload];
    base[i] = base_lines[candidates[i].base];
  }
  const LineLineSim3Estimator estimator(up, base, result.inlier_distance);
  slam::RansacOptions ransac;
  ransac.max_error = result.inlier_distance;
  ransac.min_inlier_ratio = 0.0;
  ransac.max_num_trials = options.max_trials;
  ransac.min_num_trials = std::min(options.max_trials, 50);
  ransac.random_seed = options.seed;
  const auto report = slam::Ransac(ransac, estimator);
  result.num_trials = report.num_trials;
  if (!report.success) {
    result.reason = "no Sim(3) consistent with 7 or more descriptor matches";
    return result;
  }
  result.base_from_upload = report.model;
  const Sim3d& S = report.model;

  // Chance level: the model scored on candidates whose base lines are shuffled.
  std::mt19937_64 rng(options.seed + 1);
  std::vector<int> shuffled(candidates.size());
  std::iota(shuffled.begin(), shuffled.end(), 0);
  std::shuffle(shuffled.begin(), shuffled.end(), rng);
  int chance = 0;
  for (size_t i = 0; i < candidates.size(); ++i) {
    chance += LineLineDistance(S, up[i], base[shuffled[i]]) <= result.inlier_distance;
  }
  result.chance_inliers = chance;

  // One correspondence per upload line: the closest.
  std::vector<int> best(upload_lines.size(), -1);
  std::vector<double> best_distance(upload_lines.size(), 0.0);
  double sum_sq = 0.0;
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (!report.inlier_mask[i]) continue;
    const double d = LineLineDistance(S, up[i], base[i]);
    const int u = candidates[i].upload;
    if (best[u] < 0 || d < best_distance[u]) {
      best[u] = static_cast<int>(i);
      best_distance[u] = d;
    }
  }
  for (size_t u = 0; u < best.size(); ++u) {
    if (best[u] < 0) continue;
    result.inliers.push_back(candidates[best[u]]);
    sum_sq += best_distance[u] * best_distance[u];
  }
  result.num_inliers = static_cast<int>(result.inliers.size());
  result.rms_distance =
      result.num_inliers ? std::sqrt(sum_sq / result.num_inliers) : 0.0;

  std::ostringstream why;
  if (result.num_inliers < options.min_inliers) {
    why << "too few inliers: " << result.num_inliers << " (need " << options.min_inliers << ")";
  } else if (result.num_inliers < options.min_inlier_ratio * result.num_candidates) {
    why << "inlier ratio " << static_cast<double>(result.num_inliers) / result.num_candidates
        << " below " << options.min_inlier_ratio;
  } else if (result.num_inliers < options.chance_factor * std::max(1.0, result.chance_inliers)) {
    why << "inliers " << result.num_inliers << " not above chance (" << chance
        << " with shuffled matches, factor " << options.chance_factor << ")";
  } else if (!(S.scale >= options.min_scale && S.scale <= options.max_scale)) {
    why << "implausible scale " << S.scale;
  }
  result.reason = why.str();
  result.success = result.reason.empty();
  if (result.success) {
    std::ostringstream ok;
    ok << result.num_inliers << " inliers of " << result.num_candidates << " matches (chance "
       << chance << ")";
    result.reason = ok.str();
  } else {
    result.inliers.clear();
  }
  return result;
}

}  // namespace lcv::mapping
