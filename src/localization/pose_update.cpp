#include "localization/pose_update.h"

#include <ceres/ceres.h>
#include <ceres/manifold.h>

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

namespace twocam::localization {
namespace {

double wrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

Eigen::Matrix3d planarRotation(double yaw) {
  Eigen::Matrix3d G = Eigen::Matrix3d::Identity();
  G.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(yaw).toRotationMatrix();
  return G;
}

/// Applies a world-axes planar perturbation (dx, dy, dyaw) to a pose: the body turns about its
/// own position.
Eigen::Isometry3d perturb(const Eigen::Isometry3d& T, const Eigen::Vector3d& delta) {
  Eigen::Isometry3d out = T;
  out.linear() = Eigen::AngleAxisd(delta.z(), Eigen::Vector3d::UnitZ()).matrix() * T.linear();
  out.translation() += Eigen::Vector3d(delta.x(), delta.y(), 0.0);
  return out;
}

bool residualAt(const StereoResidual& f, const Eigen::Isometry3d& T, Eigen::Vector3d* r) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d t = T.translation();
  return f(q.coeffs().data(), t.data(), r->data());
}

/// The per-observation cost of the solve: StereoResidual with analytic Jacobians.
class StereoCost final : public ceres::SizedCostFunction<3, 4, 3> {
 public:
  explicit StereoCost(const StereoResidual& f) : f_(f) {}
  bool Evaluate(double const* const* parameters,
                double* residuals,
                double** jacobians) const override {
    return stereoResidualWithJacobians(f_,
                                       parameters[0],
                                       parameters[1],
                                       residuals,
                                       jacobians != nullptr ? jacobians[0] : nullptr,
                                       jacobians != nullptr ? jacobians[1] : nullptr);
  }

 private:
  StereoResidual f_;
};

}  // namespace

bool stereoResidualWithJacobians(const StereoResidual& f,
                                 const double* q_w_b,
                                 const double* t_w_b,
                                 double* residual,
                                 double* j_q,
                                 double* j_t) {
  // p_b = conj(q) * (p_w - t) by Eigen's formula for a unit quaternion (x, y, z, w) = (u, w):
  // with a = -u (the conjugate's vector part), p_b = v + 2 w (a x v) + 2 a x (a x v).
  const Eigen::Vector3d u(q_w_b[0], q_w_b[1], q_w_b[2]);
  const double w = q_w_b[3];
  const Eigen::Vector3d v = f.p_w - Eigen::Vector3d(t_w_b[0], t_w_b[1], t_w_b[2]);
  const Eigen::Vector3d a = -u;
  const Eigen::Vector3d axv = a.cross(v);
  const Eigen::Vector3d p_b = v + 2.0 * w * axv + 2.0 * a.cross(axv);
  const Eigen::Vector3d p_c = f.R_cl_b * p_b + f.t_cl_b;
  if (!(p_c.z() > 1e-3)) return false;
  const double inv_z = 1.0 / p_c.z();
  residual[0] = (f.cx + f.fx * p_c.x() * inv_z - f.u) * f.inv_sigma_px;
  residual[1] = (f.cy + f.fy * p_c.y() * inv_z - f.v) * f.inv_sigma_px;
  residual[2] = (f.fb * inv_z - f.d) * f.inv_sigma_d;
  if (j_q == nullptr && j_t == nullptr) return true;
  // d residual / d p_c.
  Eigen::Matrix3d J_r;
  J_r << f.fx * inv_z * f.inv_sigma_px, 0.0, -f.fx * p_c.x() * inv_z * inv_z * f.inv_sigma_px,  //
      0.0, f.fy * inv_z * f.inv_sigma_px, -f.fy * p_c.y() * inv_z * inv_z * f.inv_sigma_px,     //
      0.0, 0.0, -f.fb * inv_z * inv_z * f.inv_sigma_d;
  const Eigen::Matrix3d J_rb = J_r * f.R_cl_b;  // d residual / d p_b
  if (j_q != nullptr) {
    // d p_b / d a = -2 w [v]x + 2 ((a.v) I + a v^T - 2 v a^T), and d a / d u = -I;
    // d p_b / d w = 2 (a x v).
    Eigen::Matrix3d v_x;
    v_x << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
    const Eigen::Matrix3d d_a =
        -2.0 * w * v_x + 2.0 * (a.dot(v) * Eigen::Matrix3d::Identity() + a * v.transpose() -
                                2.0 * v * a.transpose());
    Eigen::Matrix<double, 3, 4> d_q;
    d_q.leftCols<3>() = -d_a;
    d_q.col(3) = 2.0 * axv;
    Eigen::Map<Eigen::Matrix<double, 3, 4, Eigen::RowMajor>> jq_out(j_q);
    jq_out = J_rb * d_q;
  }
  if (j_t != nullptr) {
    // d p_b / d v = I + 2 w [a]x + 2 [a]x [a]x, and d v / d t = -I.
    Eigen::Matrix3d a_x;
    a_x << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
    const Eigen::Matrix3d d_v = Eigen::Matrix3d::Identity() + 2.0 * w * a_x + 2.0 * a_x * a_x;
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> jt_out(j_t);
    jt_out = -J_rb * d_v;
  }
  return true;
}

Pose2 toPose2(const Eigen::Isometry3d& T_w_b) {
  const Eigen::Vector3d x_axis = T_w_b.linear().col(0);
  return {T_w_b.translation().x(), T_w_b.translation().y(), std::atan2(x_axis.y(), x_axis.x())};
}

Pose2 odometryIncrement(const Pose2& from, const Pose2& to) {
  const double c = std::cos(from.yaw_rad);
  const double s = std::sin(from.yaw_rad);
  const double dx = to.x_m - from.x_m;
  const double dy = to.y_m - from.y_m;
  return {c * dx + s * dy, -s * dx + c * dy, wrapAngle(to.yaw_rad - from.yaw_rad)};
}

Eigen::Matrix3d odometryCovariance(const OdometryNoise& noise, double path_m, double turn_rad) {
  const OdometryErrorSigma e = accumulatedOdometrySigma(noise, path_m, turn_rad);
  return Eigen::Vector3d(e.trans_m * e.trans_m, e.trans_m * e.trans_m, e.yaw_rad * e.yaw_rad)
      .asDiagonal();
}

PoseWithCovariance predictPose(const PoseWithCovariance& previous,
                               const Pose2& increment,
                               const OdometryNoise& noise) {
  PoseWithCovariance out;
  out.T_w_b = previous.T_w_b * toIsometry(increment);
  const double yaw = toPose2(previous.T_w_b).yaw_rad;
  const Eigen::Vector2d d_w =
      Eigen::Rotation2Dd(yaw) * Eigen::Vector2d(increment.x_m, increment.y_m);
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 2) = -d_w.y();
  F(1, 2) = d_w.x();
  const Eigen::Matrix3d G = planarRotation(yaw);
  const Eigen::Matrix3d Q = odometryCovariance(
      noise, std::hypot(increment.x_m, increment.y_m), std::abs(increment.yaw_rad));
  out.cov = F * previous.cov * F.transpose() + G * Q * G.transpose();
  return out;
}

StereoResidual::StereoResidual(const StereoRig& rig,
                               const LandmarkObservation& obs,
                               const PoseUpdateOptions& o)
    : p_w(obs.p_w),
      fx(rig.fx_px),
      fy(rig.fy_px),
      cx(rig.cx_px),
      cy(rig.cy_px),
      fb(rig.fx_px * rig.baseline_m),
      u(obs.u_px),
      v(obs.v_px),
      d(obs.d_px),
      inv_sigma_px(1.0 / o.pixel_sigma_px),
      inv_sigma_d(1.0 / o.disparity_sigma_px) {
  const Eigen::Isometry3d T_cl_b = rig.T_b_cl.inverse();
  R_cl_b = T_cl_b.linear();
  t_cl_b = T_cl_b.translation();
}

PriorResidual::PriorResidual(const PoseWithCovariance& prediction, const PoseUpdateOptions& o)
    : q_p(prediction.T_w_b.linear()),
      t_p(prediction.T_w_b.translation()),
      inv_sigma_m(1.0 / o.planar_sigma_m),
      inv_sigma_rad(1.0 / o.planar_sigma_rad) {
  // A covariance that is (near) singular, e.g. zero at the first frame, is floored so that its
  // information stays finite: 1 mm and 1 mrad.
  Eigen::Matrix3d cov = prediction.cov;
  cov += Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  const Eigen::Matrix3d info = cov.inverse();
  sqrt_info = info.llt().matrixU();
}

PoseUpdateResult updatePose(const StereoRig& rig,
                            const PoseWithCovariance& prediction,
                            const std::vector<LandmarkObservation>& observations,
                            const PoseUpdateOptions& options) {
  PoseUpdateResult out;
  out.estimate = prediction;
  out.inlier.assign(observations.size(), 0);
  std::vector<StereoResidual> residuals;
  std::vector<size_t> used;
  residuals.reserve(observations.size());
  for (size_t i = 0; i < observations.size(); ++i) {
    StereoResidual f(rig, observations[i], options);
    Eigen::Vector3d r;
    if (!std::isfinite(observations[i].p_w.squaredNorm()) || !(observations[i].d_px > 0.0) ||
        !residualAt(f, prediction.T_w_b, &r)) {
      continue;
    }
    residuals.push_back(f);
    used.push_back(i);
  }
  out.observations = static_cast<int>(residuals.size());
  if (out.observations < options.min_landmarks) return out;
  if (options.max_observations > 0 &&
      residuals.size() > static_cast<size_t>(options.max_observations)) {
    const size_t n = residuals.size();
    const auto m = static_cast<size_t>(options.max_observations);
    for (size_t k = 0; k < m; ++k) {
      residuals[k] = residuals[k * n / m];
      used[k] = used[k * n / m];
    }
    residuals.erase(residuals.begin() + static_cast<std::ptrdiff_t>(m), residuals.end());
    used.resize(m);
  }

  Eigen::Quaterniond q(prediction.T_w_b.linear());
  q.normalize();
  Eigen::Vector3d t = prediction.T_w_b.translation();
  // Two stages: a Huber loss first, which converges from a prediction many sigma off (a slip),
  // then the redescending Cauchy loss from there, which stops wrong associations pulling.
  ceres::LossFunctionWrapper loss(new ceres::HuberLoss(2.0 * options.cauchy_sigma),
                                  ceres::TAKE_OWNERSHIP);
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddParameterBlock(q.coeffs().data(), 4, new ceres::EigenQuaternionManifold);
  problem.AddParameterBlock(t.data(), 3);
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PriorResidual, 6, 4, 3>(
                               new PriorResidual(prediction, options)),
                           nullptr,
                           q.coeffs().data(),
                           t.data());
  for (const StereoResidual& f : residuals) {
    problem.AddResidualBlock(new StereoCost(f), &loss, q.coeffs().data(), t.data());
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (summary.IsSolutionUsable()) {
    loss.Reset(new ceres::CauchyLoss(options.cauchy_sigma), ceres::TAKE_OWNERSHIP);
    ceres::Solve(so, &problem, &summary);
  }
  if (!summary.IsSolutionUsable() || !q.coeffs().allFinite() || !t.allFinite()) return out;

  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  // Inliers, and their information on (x, y, yaw) by central differences.
  constexpr double kEps = 1e-6;
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  int inliers = 0;
  for (size_t k = 0; k < residuals.size(); ++k) {
    Eigen::Vector3d r;
    if (!residualAt(residuals[k], T, &r) || r.squaredNorm() > options.inlier_chi2) continue;
    Eigen::Matrix3d J;
    bool ok = true;
    for (int c = 0; c < 3 && ok; ++c) {
      Eigen::Vector3d delta = Eigen::Vector3d::Zero();
      delta[c] = kEps;
      Eigen::Vector3d rp, rm;
      ok = residualAt(residuals[k], perturb(T, delta), &rp) &&
           residualAt(residuals[k], perturb(T, -delta), &rm);
      J.col(c) = (rp - rm) / (2.0 * kEps);
    }
    if (!ok) continue;
    info += J.transpose() * J;
    out.inlier[used[k]] = 1;
    ++inliers;
  }
  out.inliers = inliers;
  if (inliers < options.min_landmarks) {
    out.inlier.assign(observations.size(), 0);
    return out;
  }
  Eigen::Matrix3d prior_cov = prediction.cov;
  prior_cov += Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  out.estimate.T_w_b = T;
  out.estimate.cov = (prior_cov.inverse() + info).inverse();
  out.visual = true;
  return out;
}

PoseUpdateResult pnpPose(const StereoRig& rig,
                         const PoseWithCovariance& prediction,
                         const std::vector<LandmarkObservation>& observations,
                         const PoseUpdateOptions& update,
                         const PnpOptions& pnp) {
  PoseUpdateResult out;
  out.estimate = prediction;
  out.inlier.assign(observations.size(), 0);
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  std::vector<size_t> used;
  for (size_t i = 0; i < observations.size(); ++i) {
    const LandmarkObservation& o = observations[i];
    if (!o.p_w.allFinite() || !std::isfinite(o.u_px) || !std::isfinite(o.v_px)) continue;
    object.emplace_back(o.p_w.x(), o.p_w.y(), o.p_w.z());
    image.emplace_back(o.u_px, o.v_px);
    used.push_back(i);
  }
  out.observations = static_cast<int>(object.size());
  if (out.observations < std::max(4, update.min_landmarks)) return out;
  const Eigen::Isometry3d T_cl_w = (prediction.T_w_b * rig.T_b_cl).inverse();
  const Eigen::AngleAxisd aa(T_cl_w.linear());
  const Eigen::Vector3d r0 = aa.angle() * aa.axis();
  cv::Mat rvec = (cv::Mat_<double>(3, 1) << r0.x(), r0.y(), r0.z());
  cv::Mat tvec = (cv::Mat_<double>(3, 1) << T_cl_w.translation().x(),
                  T_cl_w.translation().y(),
                  T_cl_w.translation().z());
  const cv::Matx33d K(rig.fx_px, 0, rig.cx_px, 0, rig.fy_px, rig.cy_px, 0, 0, 1);
  cv::Mat inliers;
  bool ok = false;
  try {
    ok = cv::solvePnPRansac(object,
                            image,
                            K,
                            cv::noArray(),
                            rvec,
                            tvec,
                            true,
                            pnp.iterations,
                            static_cast<float>(pnp.reprojection_px),
                            0.99,
                            inliers,
                            cv::SOLVEPNP_ITERATIVE);
  } catch (const cv::Exception&) {
    ok = false;  // degenerate configuration: no visual pose this frame
  }
  if (!ok || inliers.rows < update.min_landmarks) return out;
  Eigen::Vector3d r, t;
  for (int k = 0; k < 3; ++k) {
    r[k] = rvec.at<double>(k);
    t[k] = tvec.at<double>(k);
  }
  if (!r.allFinite() || !t.allFinite()) return out;
  Eigen::Isometry3d T_cl_w_est = Eigen::Isometry3d::Identity();
  if (r.norm() > 0.0) T_cl_w_est.linear() = Eigen::AngleAxisd(r.norm(), r.normalized()).matrix();
  T_cl_w_est.translation() = t;
  out.estimate.T_w_b = T_cl_w_est.inverse() * rig.T_b_cl.inverse();
  out.inliers = inliers.rows;
  for (int k = 0; k < inliers.rows; ++k) out.inlier[used[inliers.at<int>(k)]] = 1;
  out.visual = true;
  return out;
}

double slipChi2(const PoseWithCovariance& start,
                const PoseWithCovariance& end,
                const Pose2& odometry_motion,
                const Eigen::Matrix3d& odometry_cov) {
  const Pose2 visual = odometryIncrement(toPose2(start.T_w_b), toPose2(end.T_w_b));
  const Eigen::Vector3d e(visual.x_m - odometry_motion.x_m,
                          visual.y_m - odometry_motion.y_m,
                          wrapAngle(visual.yaw_rad - odometry_motion.yaw_rad));
  const Eigen::Matrix3d R = planarRotation(toPose2(start.T_w_b).yaw_rad).transpose();
  Eigen::Matrix3d S = odometry_cov + R * (start.cov + end.cov) * R.transpose();
  S += Eigen::Vector3d(1e-8, 1e-8, 1e-8).asDiagonal();
  return e.dot(S.ldlt().solve(e));
}

}  // namespace twocam::localization
