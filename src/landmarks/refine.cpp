#include "landmarks/refine.h"

#include <ceres/ceres.h>

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
    const LandmarkOptions& n = o.noise_model;
    const double sigma_yaw = n.odom_rot_sigma_per_sqrt_rad * std::sqrt(std::abs(turn_rad)) +
                             n.odom_rot_scale_sigma * std::abs(turn_rad) +
                             n.odom_rot_sigma_per_m * dist_m;
    const double dd_yaw = obs.d_px * std::abs(obs.u_px - rig.cx_px) / rig.fx_px * sigma_yaw;
    const double odo2 = sigma.d_px * sigma.d_px - n.disparity_sigma_px * n.disparity_sigma_px;
    return std::sqrt(o.disparity_sigma_px * o.disparity_sigma_px + std::max(0.0, odo2) +
                     dd_yaw * dd_yaw);
  }

  template <typename T>
  bool operator()(const T* const d_anchor, T* residual) const {
    if (!(d_anchor[0] > T(1e-6))) return false;
    const T z_a = T(fb) / d_anchor[0];
    const T pa[3] = {T(xa) * z_a, T(ya) * z_a, z_a};
    T p[3];
    for (int r = 0; r < 3; ++r)
      p[r] = T(R(r, 0)) * pa[0] + T(R(r, 1)) * pa[1] + T(R(r, 2)) * pa[2] + T(t(r));
    if (!(p[2] > T(1e-6))) return false;
    residual[0] = (T(fb) / p[2] - T(d)) * T(inv_d);
    return true;
  }

  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  double fb, xa, ya, d, inv_d;
};

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
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (const Observation& obs : observations) {
    const Eigen::Isometry3d T_ck_ca = cameraPoseInWorld(obs.odom_pose, T_b_cl).inverse() * T_w_ca;
    auto* cost = new ceres::AutoDiffCostFunction<AnchoredResidual, 1, 1>(
        new AnchoredResidual(rig, T_ck_ca, anchor, obs, options));
    problem.AddResidualBlock(cost, new ceres::HuberLoss(options.huber), &d_anchor);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (summary.termination_type == ceres::FAILURE || !std::isfinite(d_anchor) || !(d_anchor > 0.0)) {
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
