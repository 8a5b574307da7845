#include "landmarks/refine.h"

#include <cmath>

#include <ceres/ceres.h>

#include "landmarks/landmark_model.h"

namespace twocam::landmarks {
namespace {

/// Stereo reprojection residual of one observation; the camera pose is a constant.
struct StereoResidual {
  StereoResidual(const StereoRig& rig, const Eigen::Isometry3d& T_cl_w, const Observation& obs, const RefineOptions& o)
      : R(T_cl_w.linear()),
        t(T_cl_w.translation()),
        fx(rig.fx_px),
        fy(rig.fy_px),
        cx(rig.cx_px),
        cy(rig.cy_px),
        fb(rig.fx_px * rig.baseline_m),
        u(obs.u_px),
        v(obs.v_px),
        d(obs.d_px),
        inv_px(1.0 / o.pixel_sigma_px),
        inv_d(1.0 / o.disparity_sigma_px) {}

  template <typename T>
  bool operator()(const T* const p_w, T* residual) const {
    T p[3];
    for (int r = 0; r < 3; ++r) {
      p[r] = T(R(r, 0)) * p_w[0] + T(R(r, 1)) * p_w[1] + T(R(r, 2)) * p_w[2] + T(t(r));
    }
    if (!(p[2] > T(1e-6))) return false;
    const T inv_z = T(1.0) / p[2];
    residual[0] = (T(cx) + T(fx) * p[0] * inv_z - T(u)) * T(inv_px);
    residual[1] = (T(cy) + T(fy) * p[1] * inv_z - T(v)) * T(inv_px);
    residual[2] = (T(fb) * inv_z - T(d)) * T(inv_d);
    return true;
  }

  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  double fx, fy, cx, cy, fb, u, v, d, inv_px, inv_d;
};

}  // namespace

RefineResult refineLandmark(const StereoRig& rig,
                            const Eigen::Isometry3d& T_b_cl,
                            const std::vector<Observation>& observations,
                            const RefineOptions& options,
                            Eigen::Vector3d* p_w,
                            double* rms_sigma) {
  if (observations.size() < 2) return RefineResult::kTooFewObservations;
  double x[3] = {p_w->x(), p_w->y(), p_w->z()};
  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  for (const Observation& obs : observations) {
    const Eigen::Isometry3d T_cl_w = cameraPoseInWorld(obs.odom_pose, T_b_cl).inverse();
    const Eigen::Vector3d p_cl = T_cl_w * *p_w;
    if (!(p_cl.z() > 0.0)) return RefineResult::kBehindCamera;
    auto* cost = new ceres::AutoDiffCostFunction<StereoResidual, 3, 3>(new StereoResidual(rig, T_cl_w, obs, options));
    problem.AddResidualBlock(cost, new ceres::HuberLoss(options.huber), x);
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  if (summary.termination_type == ceres::FAILURE || !std::isfinite(x[0]) || !std::isfinite(x[1]) ||
      !std::isfinite(x[2])) {
    return RefineResult::kNoConvergence;
  }
  const Eigen::Vector3d refined(x[0], x[1], x[2]);
  for (const Observation& obs : observations) {
    const Eigen::Vector3d p_cl = cameraPoseInWorld(obs.odom_pose, T_b_cl).inverse() * refined;
    if (!(p_cl.z() > 0.0)) return RefineResult::kBehindCamera;
  }
  *p_w = refined;
  if (rms_sigma != nullptr) {
    *rms_sigma = std::sqrt(2.0 * summary.final_cost / (3.0 * static_cast<double>(observations.size())));
  }
  return RefineResult::kOk;
}

}  // namespace twocam::landmarks
