#include "slam/module/line_cloud_view_registration.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "slam/geometry/so3.h"
#include "slam/solve/p6l.h"

namespace lcv::slam {
namespace {

constexpr double kDegree = M_PI / 180.0;

// The rotation of server_from_client that turns the view's client orientation into its p6L one
// (TransformPose: server rotation = client rotation * S.rotation^-1).
Eigen::Quaterniond ViewRotation(const LineCloudView& view) {
  return (view.server_cam_from_world.rotation.conjugate() * view.client_cam_from_world.rotation)
      .normalized();
}

// Scale and translation that put the client centres, turned by `rotation`, on the server centres
// (least squares). False when the client centres coincide or the scale is not positive.
bool FitScaleAndTranslation(const std::vector<const LineCloudView*>& views,
                            const Eigen::Quaterniond& rotation, Sim3d* server_from_client) {
  const int n = static_cast<int>(views.size());
  std::vector<Eigen::Vector3d> x(n), y(n);
  Eigen::Vector3d x_mean = Eigen::Vector3d::Zero(), y_mean = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    x[k] = rotation * views[k]->client_cam_from_world.Center();
    y[k] = views[k]->server_cam_from_world.Center();
    x_mean += x[k] / n;
    y_mean += y[k] / n;
  }
  double xx = 0.0, xy = 0.0;
  for (int k = 0; k < n; ++k) {
    xx += (x[k] - x_mean).squaredNorm();
    xy += (x[k] - x_mean).dot(y[k] - y_mean);
  }
  if (!(xx > 0.0) || !(xy > 0.0)) return false;
  const double scale = xy / xx;
  *server_from_client = Sim3d(scale, rotation, y_mean - scale * x_mean);
  return true;
}

Eigen::Quaterniond AverageRotation(const std::vector<const LineCloudView*>& views) {
  const Eigen::Quaterniond first = ViewRotation(*views.front());
  Eigen::Vector4d sum = Eigen::Vector4d::Zero();
  for (const LineCloudView* view : views) {
    Eigen::Quaterniond q = ViewRotation(*view);
    if (q.coeffs().dot(first.coeffs()) < 0.0) q.coeffs() = -q.coeffs();
    sum += q.coeffs();
  }
  Eigen::Quaterniond mean;
  mean.coeffs() = sum.normalized();
  return mean;
}

double CentreResidual(const Sim3d& server_from_client, const LineCloudView& view) {
  return (server_from_client * view.client_cam_from_world.Center() -
          view.server_cam_from_world.Center())
      .norm();
}

bool Agrees(const Sim3d& server_from_client, const LineCloudView& view, double max_centre,
            double max_rotation_rad) {
  return CentreResidual(server_from_client, view) <= max_centre &&
         AngularDistance(ViewRotation(view), server_from_client.rotation) <= max_rotation_rad;
}

// Median distance from the views' p6L centres to their inlier lines.
double MedianLineDistance(const std::vector<LineCloudView>& views) {
  std::vector<double> distances;
  for (const LineCloudView& view : views) {
    const Eigen::Vector3d centre = view.server_cam_from_world.Center();
    for (const Line3d& line : view.lines) distances.push_back(line.Residual(centre).norm());
  }
  if (distances.empty()) return 0.0;
  const auto middle = distances.begin() + distances.size() / 2;
  std::nth_element(distances.begin(), middle, distances.end());
  return *middle;
}

// Gauss-Newton (Huber on the residual, a little Levenberg damping) over server_from_client.
void Refine(const std::vector<const LineCloudView*>& views, double huber_rad, int max_iterations,
            Sim3d* server_from_client) {
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    Eigen::Matrix<double, 7, 7> hessian = Eigen::Matrix<double, 7, 7>::Zero();
    Vector7d gradient = Vector7d::Zero();
    int used = 0;
    for (const LineCloudView* view : views) {
      for (size_t i = 0; i < view->bearings.size(); ++i) {
        double r = 0.0;
        Eigen::Matrix<double, 1, 7> jacobian;
        if (!ViewBearingPlaneResidual(*server_from_client, view->client_cam_from_world,
                                      view->bearings[i], view->lines[i], &r, &jacobian)) {
          continue;
        }
        const double weight = std::abs(r) <= huber_rad ? 1.0 : huber_rad / std::abs(r);
        hessian += weight * jacobian.transpose() * jacobian;
        gradient += weight * jacobian.transpose() * r;
        ++used;
      }
    }
    if (used < 7) return;
    hessian.diagonal() += 1e-9 * hessian.diagonal().cwiseMax(1e-12);
    const Vector7d delta = hessian.ldlt().solve(-gradient);
    if (!delta.allFinite()) return;
    *server_from_client = Sim3d::Exp(delta) * *server_from_client;
    if (delta.norm() < 1e-10) return;
  }
}

}  // namespace

bool ViewBearingPlaneResidual(const Sim3d& server_from_client,
                              const Rigid3d& client_cam_from_world,
                              const Eigen::Vector3d& bearing, const Line3d& server_line,
                              double* residual, Eigen::Matrix<double, 1, 7>* jacobian) {
  const Rigid3d pose = TransformPose(server_from_client, client_cam_from_world);
  Eigen::Matrix<double, 1, 6> camera_jacobian;
  if (!BearingPlaneResidual(pose, bearing, server_line, residual,
                            jacobian != nullptr ? &camera_jacobian : nullptr)) {
    return false;
  }
  if (jacobian != nullptr) {
    // S' = Exp([v; w; l]) S moves the view's pose by the camera-side left perturbation
    // v_c = l t - R v - [t]x R w, w_c = -R w (R, t: the view's server pose); chain rule.
    const Eigen::Matrix3d rotation = pose.RotationMatrix();
    const Eigen::Matrix<double, 1, 3> jv = camera_jacobian.leftCols<3>();
    const Eigen::Matrix<double, 1, 3> jw = camera_jacobian.rightCols<3>();
    jacobian->leftCols<3>() = -jv * rotation;
    jacobian->middleCols<3>(3) =
        -jv * SkewSymmetric(pose.translation) * rotation - jw * rotation;
    (*jacobian)(6) = jv.dot(pose.translation);
  }
  return true;
}

LineCloudViewRegistration RegisterFromViews(const std::vector<LineCloudView>& views,
                                            const LineCloudViewRegistrationOptions& options) {
  LineCloudViewRegistration out;
  const int n = static_cast<int>(views.size());
  if (n < options.min_views) {
    out.failure = std::to_string(n) + " views < " + std::to_string(options.min_views);
    return out;
  }
  if (!(options.max_error_rad > 0.0)) {
    out.failure = "max_error_rad not set";
    return out;
  }
  const double depth = MedianLineDistance(views);
  if (!(depth > 0.0)) {
    out.failure = "no line distance";
    return out;
  }
  const double max_centre = options.max_centre_of_depth * depth;
  const double max_rotation = options.max_rotation_deg * kDegree;

  // 1. Hypotheses from pairs of views.
  std::vector<const LineCloudView*> best;
  double best_residual = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if (i == j) continue;
      Sim3d hypothesis;
      if (!FitScaleAndTranslation({&views[i], &views[j]}, ViewRotation(views[i]), &hypothesis)) {
        continue;
      }
      std::vector<const LineCloudView*> agreeing;
      double residual = 0.0;
      for (const LineCloudView& view : views) {
        if (!Agrees(hypothesis, view, max_centre, max_rotation)) continue;
        agreeing.push_back(&view);
        residual += CentreResidual(hypothesis, view);
      }
      if (agreeing.size() > best.size() ||
          (agreeing.size() == best.size() && residual < best_residual)) {
        best = std::move(agreeing);
        best_residual = residual;
      }
    }
  }
  if (static_cast<int>(best.size()) < options.min_views) {
    out.failure = std::to_string(best.size()) + " agreeing views < " +
                  std::to_string(options.min_views);
    return out;
  }

  // 2. The agreeing views together.
  Sim3d server_from_client;
  if (!FitScaleAndTranslation(best, AverageRotation(best), &server_from_client)) {
    out.failure = "degenerate view centres";
    return out;
  }

  // 3. Refinement on the bearings.
  const double threshold = options.max_error_rad;
  Refine(best, threshold, options.max_iterations, &server_from_client);
  if (!(server_from_client.scale > 0.0) || !server_from_client.translation.allFinite()) {
    out.failure = "refinement diverged";
    return out;
  }

  // 4. Verification.
  double span = 0.0;
  for (const LineCloudView* a : best) {
    for (const LineCloudView* b : best) {
      span = std::max(span, (server_from_client * a->client_cam_from_world.Center() -
                             server_from_client * b->client_cam_from_world.Center())
                                .norm());
    }
  }
  out.span_of_depth = span / depth;
  const double max_squared = std::sin(threshold) * std::sin(threshold);
  int total = 0;
  std::vector<Id> kept;
  for (const LineCloudView* view : best) {
    const Rigid3d pose = TransformPose(server_from_client, view->client_cam_from_world);
    int inliers = 0;
    for (size_t i = 0; i < view->bearings.size(); ++i) {
      inliers += SquaredBearingPlaneError(pose, view->bearings[i], view->lines[i]) <= max_squared;
    }
    total += inliers;
    if (inliers >= options.min_inlier_ratio * static_cast<double>(view->bearings.size())) {
      kept.push_back(view->keyframe_id);
    }
  }
  out.num_inliers = total;
  out.server_from_client = server_from_client;
  if (out.span_of_depth < options.min_span_of_depth) {
    out.failure = "views span " + std::to_string(out.span_of_depth) + " < " +
                  std::to_string(options.min_span_of_depth) + " line distances";
  } else if (static_cast<int>(kept.size()) < options.min_views) {
    out.failure = std::to_string(kept.size()) + " views keep their inliers < " +
                  std::to_string(options.min_views);
  } else if (total < options.min_inliers) {
    out.failure = std::to_string(total) + " inliers < " + std::to_string(options.min_inliers);
  } else {
    out.success = true;
  }
  out.view_keyframe_ids = std::move(kept);
  return out;
}

}  // namespace lcv::slam
