#include "landmarks/refine.h"

#include <ceres/tiny_solver.h>

#include <algorithm>
#include <cmath>

#include "landmarks/landmark_model.h"

namespace twocam::landmarks {
namespace {

/// Disparity residual of one observation for a landmark parametrised by its disparity d_a in the
/// anchor frame (on the anchor pixel's ray). T_ck_ca is a constant.
struct AnchoredResidual {
  AnchoredResidual(const StereoRig& rig,
                   const Eigen::Isometry3d& T_ck_ca,
                   const Observation& anchor,
                   const Observation& obs,
                   const RefineOptions& o)
      : R(T_ck_ca.linear()),
        t(T_ck_ca.translation()),
        fb(rig.fx_px * rig.baseline_m),
        xa((anchor.u_px - rig.cx_px) / rig.fx_px),
        ya((anchor.v_px - rig.cy_px) / rig.fy_px),
        d(obs.d_px),
        inv_d(1.0 / observationSigma(rig, anchor, obs, o)) {}

  /// The residual's sigma [px] (RefineOptions::weight_by_odometry).
  static double observationSigma(const StereoRig& rig,
                                 const Observation& anchor,
                                 const Observation& obs,
                                 const RefineOptions& o) {
    if (!o.weight_by_odometry) return o.disparity_sigma_px;
    const double dist_m = std::hypot(obs.odom_pose.x_m - anchor.odom_pose.x_m,
                                     obs.odom_pose.y_m - anchor.odom_pose.y_m);
    const double turn_rad =
        std::remainder(obs.odom_pose.yaw_rad - anchor.odom_pose.yaw_rad, 2.0 * M_PI);
    const double z_m = rig.fx_px * rig.baseline_m / std::max(1e-3, static_cast<double>(obs.d_px));
    const Eigen::Vector3d uvd(obs.u_px, obs.v_px, obs.d_px);
    const MeasurementSigma sigma = predictionSigma(o.noise_model, rig, uvd, z_m, dist_m, turn_rad);
    const TrackerOptions& n = o.noise_model;
    const double sigma_yaw = accumulatedOdometrySigma(n.odometry_noise, dist_m, turn_rad).yaw_rad;
    const double dd_yaw = obs.d_px * std::abs(obs.u_px - rig.cx_px) / rig.fx_px * sigma_yaw;
    const double odo2 = sigma.d_px * sigma.d_px - n.disparity_sigma_px * n.disparity_sigma_px;
    return std::sqrt(o.disparity_sigma_px * o.disparity_sigma_px + std::max(0.0, odo2) +
                     dd_yaw * dd_yaw);
  }

  /// Normalised residual (predicted - observed disparity) / sigma at anchor disparity d_a, and
  /// its derivative. The point on the anchor ray is p_ca = (xa, ya, 1) fb / d_a, so its depth in
  /// the observation's camera is a fb / d_a + t_z with a = R.row(2) (xa, ya, 1), and the
  /// predicted disparity fb / z = fb d_a / (a fb + t_z d_a). False when the point is behind
  /// either camera.
  bool evaluate(double d_a, double* residual, double* jacobian) const {
    if (!(d_a > 1e-6)) return false;
    const double a = R(2, 0) * xa + R(2, 1) * ya + R(2, 2);
    const double denom = a * fb + t.z() * d_a;
    if (!(denom > 1e-6 * d_a)) return false;  // z = denom / d_a must be positive
    *residual = (fb * d_a / denom - d) * inv_d;
    *jacobian = fb * fb * a / (denom * denom) * inv_d;
    return true;
  }

  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  double fb, xa, ya, d, inv_d;
};

/// The problem for Ceres' TinySolver (Levenberg-Marquardt for small dense problems, no heap work
/// per iteration; the general ceres::Problem spent most of its time building and tearing down
/// the problem, which for one parameter and 24 residuals dominated the landmark update). The
/// Huber loss rho(s) = s for s <= k^2, 2 k sqrt(s) - k^2 beyond (ceres::HuberLoss) enters in
/// square-root form: each residual r becomes sign(r) sqrt(rho(r^2)), so the sum of squares is
/// exactly the robust cost, and its slope is scaled by k / |r~| beyond the kink (C1 at |r| = k).
/// A point behind a camera gets a large residual, so a step that goes there is rejected.
struct HuberProblem {
  using Scalar = double;
  // NOLINTNEXTLINE(readability-identifier-naming): names fixed by ceres::TinySolver.
  enum { NUM_RESIDUALS = Eigen::Dynamic, NUM_PARAMETERS = 1 };
  const std::vector<AnchoredResidual>* residuals;
  double k;

  // NOLINTNEXTLINE(readability-identifier-naming): ceres::TinySolver's name.
  [[nodiscard]] int NumResiduals() const { return static_cast<int>(residuals->size()); }

  bool operator()(const double* params, double* out, double* jacobian) const {
    constexpr double kInvalidResidual = 1e6;
    for (size_t i = 0; i < residuals->size(); ++i) {
      double r = 0.0, j = 0.0;
      if (!(*residuals)[i].evaluate(params[0], &r, &j)) {
        r = kInvalidResidual;
        j = 0.0;
      }
      const double abs_r = std::abs(r);
      if (abs_r > k) {
        const double robust = std::sqrt(2.0 * k * abs_r - k * k);
        j *= k / robust;
        r = std::copysign(robust, r);
      }
      out[i] = r;
      if (jacobian != nullptr) jacobian[i] = j;
    }
    return true;
  }
};

/// Scratch space of the refinement, reused between calls (one per thread).
thread_local std::vector<AnchoredResidual> t_residual_scratch;

}  // namespace

RefineResult refineLandmark(const StereoRig& rig,
                            const Eigen::Isometry3d& T_b_cl,
                            const std::vector<Observation>& observations,
                            const RefineOptions& options,
                            Eigen::Vector3d* p_w,
                            double* rms_sigma) {
  if (observations.size() < 2) return RefineResult::kTooFewObservations;
  const Observation& anchor = observations.front();
  const Eigen::Isometry3d T_w_ca = cameraPoseInWorld(anchor.odom_pose, T_b_cl);
  // Start from the current estimate's disparity in the anchor frame.
  const Eigen::Vector3d p_ca = T_w_ca.inverse() * *p_w;
  if (!(p_ca.z() > 0.0)) return RefineResult::kBehindCamera;
  double d_anchor = rig.fx_px * rig.baseline_m / p_ca.z();
  std::vector<AnchoredResidual>& residuals = t_residual_scratch;
  residuals.clear();
  for (const Observation& obs : observations) {
    const Eigen::Isometry3d T_ck_ca = cameraPoseInWorld(obs.odom_pose, T_b_cl).inverse() * T_w_ca;
    residuals.emplace_back(rig, T_ck_ca, anchor, obs, options);
  }
  const HuberProblem problem{&residuals, options.huber};
  ceres::TinySolver<HuberProblem> solver;
  solver.options.max_num_iterations = options.max_iterations + 1;  // it counts the first evaluation
  Eigen::Matrix<double, 1, 1> x(d_anchor);
  const auto& summary = solver.Solve(problem, &x);
  d_anchor = x(0);
  if (!std::isfinite(d_anchor) || !(d_anchor > 0.0)) {
    return RefineResult::kNoConvergence;
  }
  if (std::abs(d_anchor - anchor.d_px) >
      options.max_anchor_shift_sigmas * options.disparity_sigma_px) {
    return RefineResult::kDisagreesWithAnchor;
  }
  const auto p = triangulateRectified(rig, Eigen::Vector2d(anchor.u_px, anchor.v_px), d_anchor);
  if (!p) return RefineResult::kNoConvergence;
  *p_w = T_w_ca * *p;
  if (rms_sigma != nullptr) {
    *rms_sigma = std::sqrt(2.0 * summary.final_cost / static_cast<double>(observations.size()));
  }
  return RefineResult::kOk;
}

}  // namespace twocam::landmarks
