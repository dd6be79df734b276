#include "slam/module/line_cloud_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Eigenvalues>

#include "slam/optimize/motion_only_ba.h"
#include "slam/optimize/rigid_stereo_ba.h"
#include "slam/solve/p4l.h"
#include "slam/solve/point_line_sim3.h"
#include "slam/solve/ransac.h"
#include "slam/solve/umeyama.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// A client point index paired with a target (line or server point) index.
struct IndexPair {
  int point = -1;
  int target = -1;
};

// Hamming 2-NN of every client point among the targets, ratio test and cap; per target the
// closest client point (one-to-one). Ordered by target index (deterministic).
std::vector<IndexPair> MatchDescriptors(const std::vector<RegistrationPoint>& points,
                                        const std::vector<OrbDescriptor>& targets,
                                        const LineCloudRegistrationOptions& options) {
  std::vector<IndexPair> best_of_target(targets.size());
  std::vector<int> best_distance_of_target(targets.size(), NearestTwo::kNone);
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    NearestTwo nearest;
    for (int j = 0; j < static_cast<int>(targets.size()); ++j) {
      nearest.Offer(HammingDistance(points[i].descriptor, targets[j]), j);
    }
    const int best = nearest.best, second = nearest.second, best_target = nearest.index;
    if (best_target < 0 || best > options.max_hamming_distance) continue;
    if (second != NearestTwo::kNone && !(best < options.ratio * second)) continue;
    if (best < best_distance_of_target[best_target]) {
      best_distance_of_target[best_target] = best;
      best_of_target[best_target] = {i, best_target};
    }
  }
  std::vector<IndexPair> out;
  for (const IndexPair& pair : best_of_target) {
    if (pair.point >= 0) out.push_back(pair);
  }
  return out;
}

// An estimator of server_from_client whose squared residuals are divided by (s * range_i)^2,
// range_i = |X_i - c_ckf| in client units: the scale-free error of the header (step 3).
template <typename Inner>
class RelativeErrorEstimator {
 public:
  using Model = Sim3d;
  static constexpr int kMinNumSamples = Inner::kMinNumSamples;

  RelativeErrorEstimator(const Inner& inner, const std::vector<double>& inverse_ranges)
      : inner_(inner), inverse_ranges_(inverse_ranges) {}

  int NumData() const { return inner_.NumData(); }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const {
    inner_.Estimate(sample, models);
  }
  void Residuals(const Model& server_from_client, std::vector<double>* squared_residuals) const {
    inner_.Residuals(server_from_client, squared_residuals);
    const double s = server_from_client.scale;
    if (!(s > 0.0) || !std::isfinite(s)) {
      std::fill(squared_residuals->begin(), squared_residuals->end(),
                std::numeric_limits<double>::infinity());
      return;
    }
    const double inverse_s2 = 1.0 / (s * s);
    for (size_t i = 0; i < squared_residuals->size(); ++i) {
      (*squared_residuals)[i] *= inverse_s2 * inverse_ranges_[i] * inverse_ranges_[i];
    }
  }
  bool Refine(const std::vector<int>& inliers, Model* server_from_client) const {
    return inner_.Refine(inliers, server_from_client);
  }

 private:
  const Inner& inner_;
  const std::vector<double>& inverse_ranges_;
};

// Inlier flags of all data of an estimator at a model (relative error <= threshold).
template <typename Estimator>
std::vector<char> InlierMask(const Estimator& estimator, const Sim3d& model, double threshold) {
  std::vector<double> squared;
  estimator.Residuals(model, &squared);
  std::vector<char> mask(squared.size(), 0);
  for (size_t i = 0; i < squared.size(); ++i) mask[i] = squared[i] <= threshold * threshold;
  return mask;
}

int Count(const std::vector<char>& mask) {
  return static_cast<int>(std::count(mask.begin(), mask.end(), 1));
}

// Standard deviation of the points along their second principal axis (their units): ~0 for
// (nearly) collinear points.
double SecondPrincipalDeviation(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 3) return 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) covariance += (p - mean) * (p - mean).transpose();
  covariance /= static_cast<double>(points.size());
  const Eigen::Vector3d eigenvalues =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance, Eigen::EigenvaluesOnly)
          .eigenvalues();  // ascending
  return std::sqrt(std::max(0.0, eigenvalues(1)));
}

// The similarity with the scale of `scale` whose rotation and translation map the client
// camera pose onto the server camera pose: TransformPose(result, cam_from_client) equals
// cam_from_server.
Sim3d SimilarityFromPoses(double scale, const Rigid3d& cam_from_client,
                          const Rigid3d& cam_from_server) {
  const Eigen::Quaterniond rotation =
      (cam_from_server.rotation.conjugate() * cam_from_client.rotation).normalized();
  const Eigen::Vector3d translation =
      cam_from_server.Center() - scale * (rotation * cam_from_client.Center());
  return Sim3d(scale, rotation, translation);
}

std::string BelowLimit(int count, const char* what, int limit) {
  return std::to_string(count) + " " + what + " < " + std::to_string(limit);
}

}  // namespace

std::string LineCloudRegistrationOptions::Problem() const {
  if (max_hamming_distance < 0 || max_hamming_distance > 256)
    return "max_hamming_distance must be in [0, 256]";
  if (!(ratio > 0.0 && ratio <= 1.0)) return "ratio must be in (0, 1]";
  if (min_matches < 4) return "min_matches must be >= 4 (P4L's minimal sample)";
  if (!(max_relative_error > 0.0)) return "max_relative_error must be > 0";
  if (max_ransac_trials < 1) return "max_ransac_trials must be >= 1";
  if (!(ransac_confidence > 0.0 && ransac_confidence < 1.0))
    return "ransac_confidence must be in (0, 1)";
  if (min_inliers < 4) return "min_inliers must be >= 4";
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0))
    return "min_inlier_ratio must be in [0, 1]";
  if (!(min_scale > 0.0 && max_scale > min_scale))
    return "scale range must satisfy 0 < min_scale < max_scale";
  if (!(min_spread_in_thresholds >= 0.0)) return "min_spread_in_thresholds must be >= 0";
  const std::string bundle_problem = bundle.Problem();
  if (!bundle_problem.empty()) return "bundle: " + bundle_problem;
  return "";
}

LineCloudRegistration RegisterToLineCloud(const std::vector<RegistrationView>& views,
                                          const std::vector<RegistrationPoint>& points,
                                          const std::vector<RegistrationLine>& lines,
                                          const std::vector<RegistrationServerPoint>& server_points,
                                          const LineCloudRegistrationOptions& options) {
  const std::string options_problem = options.Problem();
  LCV_CHECK(options_problem.empty()) << options_problem;
  LCV_CHECK(!views.empty()) << "RegisterToLineCloud needs the current keyframe as views[0]";
  for (size_t v = 0; v < views.size(); ++v) {
    LCV_CHECK(views[v].camera != nullptr) << "views[" << v << "] has no camera";
  }
  for (size_t i = 0; i < points.size(); ++i) {
    for (const RegistrationObservation& obs : points[i].observations) {
      LCV_CHECK(obs.view >= 0 && obs.view < static_cast<int>(views.size()))
          << "points[" << i << "]: observation view " << obs.view << " out of range";
    }
  }
  LineCloudRegistration result;

  // 1. Descriptor matching.
  std::vector<OrbDescriptor> descriptors;
  descriptors.reserve(std::max(lines.size(), server_points.size()));
  for (const RegistrationLine& line : lines) descriptors.push_back(line.descriptor);
  const std::vector<IndexPair> line_matches = MatchDescriptors(points, descriptors, options);
  descriptors.clear();
  for (const RegistrationServerPoint& p : server_points) descriptors.push_back(p.descriptor);
  const std::vector<IndexPair> point_matches = MatchDescriptors(points, descriptors, options);
  const int num_pl = static_cast<int>(line_matches.size());
  const int num_pp = static_cast<int>(point_matches.size());
  result.num_point_line_matches = num_pl;
  result.num_point_point_matches = num_pp;
  if (num_pl + num_pp < options.min_matches) {
    result.failure = std::to_string(num_pl) + " point-line + " + std::to_string(num_pp) +
                     " point-point matches < " + std::to_string(options.min_matches);
    return result;
  }

  // 2. The paper's rule: P4L if N_PL / N_PP > 4/3 (written without the division).
  const bool use_p4l = 3 * num_pl > 4 * num_pp;
  result.method = use_p4l ? "p4l" : "p3p";

  // Correspondence arrays and each point's inverse range from the ckf centre (client units).
  const Eigen::Vector3d ckf_center = views[0].cam_from_world.Center();
  auto inverse_range = [&](int point) {
    const double range = (points[point].position - ckf_center).norm();
    return 1.0 / std::max(range, 1e-12);
  };
  std::vector<Eigen::Vector3d> pl_points, pp_points, pp_server;
  std::vector<Line3d> pl_lines;
  std::vector<double> pl_inverse_ranges, pp_inverse_ranges;
  for (const IndexPair& m : line_matches) {
    pl_points.push_back(points[m.point].position);
    pl_lines.push_back(lines[m.target].line);
    pl_inverse_ranges.push_back(inverse_range(m.point));
  }
  for (const IndexPair& m : point_matches) {
    pp_points.push_back(points[m.point].position);
    pp_server.push_back(server_points[m.target].position);
    pp_inverse_ranges.push_back(inverse_range(m.point));
  }
  const P4LEstimator p4l(pl_points.data(), pl_lines.data(), num_pl);
  const Sim3PointEstimator p3p(pp_points.data(), pp_server.data(), num_pp);
  const RelativeErrorEstimator<P4LEstimator> relative_p4l(p4l, pl_inverse_ranges);
  const RelativeErrorEstimator<Sim3PointEstimator> relative_p3p(p3p, pp_inverse_ranges);

  // What step 4's verification asks of a model: min_inliers, and min_inlier_ratio of the matches.
  const int needed_in_all = std::max(
      options.min_inliers,
      static_cast<int>(std::ceil(options.min_inlier_ratio * (num_pl + num_pp) - 1e-9)));

  // The prior (see LineCloudRegistrationOptions::prior): does the map already agree?
  if (options.prior) {
    result.num_point_line_inliers =
        Count(InlierMask(relative_p4l, *options.prior, options.max_relative_error));
    result.num_point_point_inliers =
        Count(InlierMask(relative_p3p, *options.prior, options.max_relative_error));
    result.num_inliers = result.num_point_line_inliers + result.num_point_point_inliers;
    if (result.num_inliers >= needed_in_all) {
      result.prior_holds = true;
      result.server_from_client = *options.prior;
      result.failure = "the prior model holds: " + std::to_string(result.num_inliers) +
                       " of " + std::to_string(num_pl + num_pp) + " matches agree";
      return result;
    }
    result.num_point_line_inliers = result.num_point_point_inliers = result.num_inliers = 0;
  }

  // 3. RANSAC on the chosen kind (LO-RANSAC: RefineSim3PointLine / Umeyama on the inliers).
  // A model that passes step 4 has at least `needed` inliers of the sampled kind (the other
  // kind adds at most all of its matches), so RANSAC can stop once an all-inlier sample of such
  // a model would have been drawn with ransac_confidence. A registration that succeeds draws
  // one sooner and is unchanged; an attempt that cannot succeed (a detached client's loop check
  // among a few chance matches, a first attempt with few matches) stops long before
  // max_ransac_trials (those ran all 1000 P4L samples, ~0.1 s each attempt).
  const int num_sampled = use_p4l ? num_pl : num_pp;
  const int num_other = use_p4l ? num_pp : num_pl;
  const int samples = use_p4l ? P4LEstimator::kMinNumSamples : Sim3PointEstimator::kMinNumSamples;
  const int needed = std::max(needed_in_all - num_other, samples);
  if (needed > num_sampled) {
    result.failure = "RANSAC (" + result.method + "): " + std::to_string(num_pl + num_pp) +
                     " matches cannot give " + std::to_string(needed_in_all) + " inliers";
    return result;
  }
  RansacOptions ransac;
  ransac.max_error = options.max_relative_error;
  ransac.min_inlier_ratio = 0.0;  // verified below over both kinds
  ransac.confidence = options.ransac_confidence;
  ransac.max_num_trials = RequiredRansacTrials(static_cast<double>(needed) / num_sampled, samples,
                                               options.ransac_confidence,
                                               options.max_ransac_trials);
  ransac.random_seed = options.random_seed;
  const RansacReport<Sim3d> report =
      use_p4l ? Ransac(ransac, relative_p4l) : Ransac(ransac, relative_p3p);
  result.num_ransac_trials = report.num_trials;
  const std::string stage = "RANSAC (" + result.method + "): ";
  if (report.num_trials == 0 || report.inlier_mask.empty()) {
    result.failure =
        stage + "no model from " + std::to_string(use_p4l ? num_pl : num_pp) + " matches";
    return result;
  }
  Sim3d server_from_client = report.model;

  // 4. P4L: one more RefineSim3PointLine (10 iterations, LO-RANSAC's has 5) on all point-line
  // inliers, kept when it loses no inlier; then verification over both kinds.
  std::vector<char> pl_inliers =
      InlierMask(relative_p4l, server_from_client, options.max_relative_error);
  {
    std::vector<int> indices;
    for (int i = 0; i < num_pl; ++i) {
      if (pl_inliers[i]) indices.push_back(i);
    }
    Sim3d refined = server_from_client;
    if (use_p4l && indices.size() >= 4 &&
        RefineSim3PointLine(pl_points.data(), pl_lines.data(), num_pl, &indices, 10, &refined) >=
            0) {
      const std::vector<char> refined_inliers =
          InlierMask(relative_p4l, refined, options.max_relative_error);
      if (Count(refined_inliers) >= Count(pl_inliers)) {
        server_from_client = refined;
        pl_inliers = refined_inliers;
      }
    }
  }
  const std::vector<char> pp_inliers =
      InlierMask(relative_p3p, server_from_client, options.max_relative_error);
  result.num_point_line_inliers = Count(pl_inliers);
  result.num_point_point_inliers = Count(pp_inliers);
  result.num_inliers = result.num_point_line_inliers + result.num_point_point_inliers;
  if (result.num_inliers < options.min_inliers) {
    result.failure = stage + BelowLimit(result.num_inliers, "inliers", options.min_inliers);
    return result;
  }
  const double inlier_ratio = static_cast<double>(result.num_inliers) / (num_pl + num_pp);
  if (inlier_ratio < options.min_inlier_ratio) {
    result.failure = stage + "inlier ratio " + std::to_string(inlier_ratio) + " < " +
                     std::to_string(options.min_inlier_ratio);
    return result;
  }
  const double scale = server_from_client.scale;
  if (!(scale >= options.min_scale && scale <= options.max_scale)) {
    result.failure = stage + "degenerate scale " + std::to_string(scale) + " outside [" +
                     std::to_string(options.min_scale) + ", " + std::to_string(options.max_scale) +
                     "]";
    return result;
  }
  std::vector<Eigen::Vector3d> inlier_positions;
  std::vector<double> inlier_ranges;
  for (int i = 0; i < num_pl; ++i) {
    if (!pl_inliers[i]) continue;
    inlier_positions.push_back(pl_points[i]);
    inlier_ranges.push_back(1.0 / pl_inverse_ranges[i]);
  }
  for (int i = 0; i < num_pp; ++i) {
    if (!pp_inliers[i]) continue;
    inlier_positions.push_back(pp_points[i]);
    inlier_ranges.push_back(1.0 / pp_inverse_ranges[i]);
  }
  std::nth_element(inlier_ranges.begin(), inlier_ranges.begin() + inlier_ranges.size() / 2,
                   inlier_ranges.end());
  const double noise_level = options.max_relative_error * inlier_ranges[inlier_ranges.size() / 2];
  const double spread = SecondPrincipalDeviation(inlier_positions) / noise_level;
  if (!(spread >= options.min_spread_in_thresholds)) {
    result.failure = stage + "inlier points nearly collinear (second principal deviation " +
                     std::to_string(spread) + " inlier thresholds < " +
                     std::to_string(options.min_spread_in_thresholds) + ")";
    return result;
  }

  // 5. Rigid-stereo BA. Views relative to the ckf, translations in server units.
  const Rigid3d ckf_from_client = views[0].cam_from_world;
  const Rigid3d client_from_ckf = ckf_from_client.Inverse();
  std::vector<RigidStereoView> ba_views(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    Rigid3d cam_from_ckf = views[v].cam_from_world * client_from_ckf;
    cam_from_ckf.translation *= scale;
    ba_views[v].cam_from_reference = v == 0 ? Rigid3d() : cam_from_ckf;
    ba_views[v].camera = views[v].camera;
  }
  Rigid3d ckf_from_server = TransformPose(server_from_client, ckf_from_client);
  std::vector<RigidStereoLine> ba_lines;
  std::vector<RigidStereoObservation> ba_observations;
  struct BaMatch {
    bool on_line = true;
    int match = -1;  // index into line_matches or point_matches
  };
  std::vector<BaMatch> ba_matches;  // one per ba_lines entry
  auto add_observations = [&](const RegistrationPoint& point) {
    for (const RegistrationObservation& obs : point.observations) {
      RigidStereoObservation o;
      o.view = obs.view;
      o.line = static_cast<int>(ba_lines.size());
      o.observed_px = obs.observed_px;
      o.information = obs.information;
      ba_observations.push_back(o);
    }
  };
  for (int i = 0; i < num_pl; ++i) {
    const RegistrationPoint& point = points[line_matches[i].point];
    if (!pl_inliers[i] || point.observations.empty()) continue;
    const RegistrationLine& line = lines[line_matches[i].target];
    RigidStereoLine ba_line;
    ba_line.line = line.line;
    ba_line.information = line.information;
    // The paper's initial X': midpoint of the first observation's ray and the line.
    const RegistrationObservation& first = point.observations.front();
    const Rigid3d cam_from_server = ba_views[first.view].cam_from_reference * ckf_from_server;
    const std::optional<Eigen::Vector3d> bearing =
        views[first.view].camera->Unproject(first.observed_px);
    ba_line.restored_point =
        bearing ? InitialRestoredPoint(cam_from_server, bearing->normalized(), line.line)
                : line.line.Project(server_from_client * point.position);
    add_observations(point);
    ba_lines.push_back(ba_line);
    ba_matches.push_back({true, i});
  }
  for (int i = 0; i < num_pp; ++i) {
    const RegistrationPoint& point = points[point_matches[i].point];
    if (!pp_inliers[i] || point.observations.empty()) continue;
    RigidStereoLine ba_point;
    ba_point.line =
        Line3d(server_points[point_matches[i].target].position, Eigen::Vector3d::UnitX());
    ba_point.restored_point = ba_point.line.anchor;
    ba_point.fixed = true;
    add_observations(point);
    ba_lines.push_back(ba_point);
    ba_matches.push_back({false, i});
  }
  if (static_cast<int>(ba_lines.size()) < options.min_inliers) {
    result.failure = "rigid-stereo BA: " + BelowLimit(static_cast<int>(ba_lines.size()),
                                                      "observed inliers", options.min_inliers);
    return result;
  }
  bool scale_observable = false;
  for (const RigidStereoObservation& obs : ba_observations) scale_observable |= obs.view != 0;
  double group_scale = 1.0;  // on the RANSAC scale, when refined
  const BundleReport ba =
      SolveRigidStereoBA(options.bundle, ba_views, &ckf_from_server, &ba_lines, &ba_observations,
                         options.refine_scale_in_ba && scale_observable ? &group_scale : nullptr);
  result.num_ba_outlier_observations = ba.num_outliers;
  if (!ba.success) {
    result.failure = "rigid-stereo BA failed: " + ba.message;
    return result;
  }
  std::vector<int> inlier_observations(ba_lines.size(), 0);
  for (const RigidStereoObservation& obs : ba_observations) {
    if (!obs.outlier) ++inlier_observations[obs.line];
  }
  int kept = 0;
  for (size_t k = 0; k < ba_lines.size(); ++k) kept += inlier_observations[k] > 0;
  if (kept < options.min_inliers) {
    result.failure = "rigid-stereo BA: " + BelowLimit(kept, "matches kept", options.min_inliers);
    return result;
  }

  // 6. The RANSAC scale (times the BA's group scale when refined), the ckf at its BA pose.
  result.server_from_client =
      SimilarityFromPoses(scale * group_scale, ckf_from_client, ckf_from_server);
  for (size_t k = 0; k < ba_lines.size(); ++k) {
    if (inlier_observations[k] == 0) continue;
    if (ba_matches[k].on_line) {
      const IndexPair& m = line_matches[ba_matches[k].match];
      result.restored.push_back(
          {points[m.point].landmark_id, lines[m.target].line_id, ba_lines[k].restored_point});
    } else {
      const IndexPair& m = point_matches[ba_matches[k].match];
      result.point_matches.emplace_back(points[m.point].landmark_id, server_points[m.target].id);
    }
  }
  result.success = true;
  return result;
}

}  // namespace lcv::slam
