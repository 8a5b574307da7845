#pragma once
/// The pose of one frame (docs/localization.md): predicted from the previous estimate and the
/// wheel-odometry increment with the covariance of the one odometry noise model
/// (common/odometry_noise.h), then corrected by the frame's stereo observations (u, v, d) of
/// confirmed landmarks in a robust Ceres solve. The pose is 6-DoF inside (quaternion manifold);
/// odometry is a planar factor on (x, y, yaw) and a soft planar prior holds height, roll and
/// pitch near the prediction. And the slip test: odometry's motion over a short window against
/// the visual estimates'.
///
/// Frames: w = the robot's world frame (equals the true world at the first frame), b = body,
/// cl = left camera optical frame (common/rig.h T_b_cl).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "common/frames.h"
#include "common/odometry_noise.h"
#include "common/rig.h"
#include "localization/options.h"

namespace twocam::localization {

/// One observation of a confirmed landmark in the current frame.
struct LandmarkObservation {
  uint64_t id = 0;                                ///< landmark id, for the caller
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  ///< the landmark's map position [m]
  double u_px = 0.0;                              ///< observed left column [px]
  double v_px = 0.0;                              ///< observed row [px]
  double d_px = 0.0;                              ///< observed disparity [px]
};

/// A pose with the covariance of its planar part: (x [m], y [m], yaw [rad]), world axes.
struct PoseWithCovariance {
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
};

/// The odometry increment from `from` to `to`, in the body frame of `from` (dx, dy, dyaw).
Pose2 odometryIncrement(const Pose2& from, const Pose2& to);

/// Covariance of the error of an odometry motion `motion` (body frame of its start) after a
/// path of path_m [m] and an absolute turn turn_rad [rad]: diag(sigma_t^2, sigma_t^2,
/// sigma_yaw^2) from accumulatedOdometrySigma.
Eigen::Matrix3d odometryCovariance(const OdometryNoise& noise, double path_m, double turn_rad);

/// The prediction T_w_b * increment; covariance F P F^T + G Q G^T with Q the increment's
/// (odometryCovariance over |increment|) rotated into world axes.
PoseWithCovariance predictPose(const PoseWithCovariance& previous,
                               const Pose2& increment,
                               const OdometryNoise& noise);

struct PoseUpdateResult {
  PoseWithCovariance estimate;
  /// The visual correction was made (at least min_landmarks inliers); otherwise `estimate` is
  /// the prediction.
  bool visual = false;
  int observations = 0;  ///< in front of the predicted camera, given to the solver
  int inliers = 0;       ///< squared normalised residual <= inlier_chi2 at the solution
  /// Per observation of the input: inlier at the solution (false for those not used).
  std::vector<uint8_t> inlier;
};

/// The robust pose update: minimises the prior's planar factor (Mahalanobis with
/// prediction.cov), the soft planar prior and Huber-robust stereo reprojection residuals of the
/// observations. The covariance of the result is (cov^-1 + J^T J)^-1 with J the inliers'
/// Jacobian with respect to (x, y, yaw).
PoseUpdateResult updatePose(const StereoRig& rig,
                            const PoseWithCovariance& prediction,
                            const std::vector<LandmarkObservation>& observations,
                            const PoseUpdateOptions& options);

/// How updatePose solves. All give the same minimisation up to rounding or the solvers'
/// stopping tolerance (tests/localization/pose_update_test.cpp); the Ceres layouts are kept as
/// the reference of those tests and of localization_bench.
enum class StereoCostLayout {
  /// TinySolver's Levenberg-Marquardt step for step on the 6 tangent parameters of TangentPose,
  /// the normal equations summed per observation instead of formed from a stored n x 6
  /// Jacobian (docs/localization.md, "Speed"). The default.
  kNormalEquations,
  /// Ceres' TinySolver (Levenberg-Marquardt for small dense problems) on the same parameters,
  /// the loss applied inside: no ceres::Problem to build, the normal equations formed by one
  /// matrix product.
  kTinySolver,
  kOneBlock,        ///< ceres::Problem, one cost function, 3 rows per observation, the loss inside
  kPerObservation,  ///< ceres::Problem, one residual block per observation with Ceres' loss
};

/// updatePose solved as `layout` says (the overload above: kNormalEquations).
PoseUpdateResult updatePose(const StereoRig& rig,
                            const PoseWithCovariance& prediction,
                            const std::vector<LandmarkObservation>& observations,
                            const PoseUpdateOptions& options,
                            StereoCostLayout layout);

/// Normalised stereo residual of one observation for a body pose (q_w_b, t_w_b): ((u, v, d)
/// predicted - observed) / sigma. Templated for Ceres's automatic differentiation; public for
/// the Jacobian test.
struct StereoResidual {
  StereoResidual(const StereoRig& rig, const LandmarkObservation& obs, const PoseUpdateOptions& o);
  template <typename T>
  bool operator()(const T* q_w_b, const T* t_w_b, T* residual) const;

  Eigen::Matrix3d R_cl_b;
  Eigen::Vector3d t_cl_b;
  Eigen::Vector3d p_w;
  double fx, fy, cx, cy, fb;
  double u, v, d;
  double inv_sigma_px, inv_sigma_d;
};

/// StereoResidual with its Jacobians written out (the solver's per-observation cost; auto-diff
/// of operator() cost 3x more per frame, docs/localization.md). q_w_b in Eigen's coefficient
/// order (x, y, z, w), the rotation taken by Eigen's unit-quaternion formula as operator() does,
/// so both give the same derivatives. j_q (3 x 4) and j_t (3 x 3) are row-major, either may be
/// null. False where operator() is false (behind the camera).
bool stereoResidualWithJacobians(const StereoResidual& f,
                                 const double* q_w_b,
                                 const double* t_w_b,
                                 double* residual,
                                 double* j_q,
                                 double* j_t);

/// The TinySolver's pose parameters: x = (theta, dt) about a base pose (R_0, t_0), R = Exp(theta)
/// R_0 (theta in world axes, so theta.z() turns the body about the world's vertical as a yaw
/// change does) and t = t_0 + dt. Holds what every observation's residual at x shares.
struct TangentPose {
  /// R_cl_b: the rig's body-to-left-camera rotation (StereoResidual::R_cl_b).
  TangentPose(const Eigen::Isometry3d& T_0,
              const Eigen::Matrix<double, 6, 1>& x,
              const Eigen::Matrix3d& R_cl_b);
  Eigen::Isometry3d T_w_b;    ///< the pose at x
  Eigen::Matrix3d B_cl_w;     ///< R_cl_b R^T: a world vector into the left camera
  Eigen::Matrix3d right_jac;  ///< SO(3)'s right Jacobian at -theta
};

/// StereoResidual at a TangentPose with its Jacobian (3 x 6 row-major, columns theta then dt;
/// null: none) with respect to x. False where operator() is false (behind the camera).
bool stereoTangentResidual(const StereoResidual& f,
                           const TangentPose& at,
                           double* residual,
                           double* jacobian);

/// The prior's residual: planar part sqrt_info (x - x_p, y - y_p, yaw - yaw_p) in world axes,
/// then (height change / planar_sigma_m, roll change / planar_sigma_rad, pitch change /
/// planar_sigma_rad) in the predicted body frame.
struct PriorResidual {
  PriorResidual(const PoseWithCovariance& prediction, const PoseUpdateOptions& o);
  template <typename T>
  bool operator()(const T* q_w_b, const T* t_w_b, T* residual) const;

  Eigen::Quaterniond q_p;
  Eigen::Vector3d t_p;
  Eigen::Matrix3d sqrt_info;  // upper triangular, sqrt_info^T sqrt_info = cov^-1
  double inv_sigma_m, inv_sigma_rad;
};

/// Slip test over a window: the visual motion from `start` to `end` against odometry's motion
/// over the same frames (`odometry_motion`, body frame of the start, with covariance
/// `odometry_cov`). Returns the chi-square (3 dof) of the difference (dx, dy, dyaw) with
/// covariance odometry_cov + both estimates' covariances (rotated into the start's body axes).
double slipChi2(const PoseWithCovariance& start,
                const PoseWithCovariance& end,
                const Pose2& odometry_motion,
                const Eigen::Matrix3d& odometry_cov);

// ---- the residuals' templates (used with Ceres Jets and with double) -------------------------

template <typename T>
bool StereoResidual::operator()(const T* q_w_b, const T* t_w_b, T* residual) const {
  const Eigen::Map<const Eigen::Quaternion<T>> q(q_w_b);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(t_w_b);
  const Eigen::Matrix<T, 3, 1> p_b = q.conjugate() * (p_w.cast<T>() - t);
  const Eigen::Matrix<T, 3, 1> p_c = R_cl_b.cast<T>() * p_b + t_cl_b.cast<T>();
  if (!(p_c.z() > T(1e-3))) return false;  // behind the camera: not a valid pose
  const T inv_z = T(1.0) / p_c.z();
  residual[0] = (T(cx) + T(fx) * p_c.x() * inv_z - T(u)) * T(inv_sigma_px);
  residual[1] = (T(cy) + T(fy) * p_c.y() * inv_z - T(v)) * T(inv_sigma_px);
  residual[2] = (T(fb) * inv_z - T(d)) * T(inv_sigma_d);
  return true;
}

template <typename T>
bool PriorResidual::operator()(const T* q_w_b, const T* t_w_b, T* residual) const {
  const Eigen::Map<const Eigen::Quaternion<T>> q(q_w_b);
  const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(t_w_b);
  // Rotation change in the predicted body frame as a rotation vector: 2 vec(dq) with w >= 0,
  // exact to second order (the changes are small), and smooth at zero.
  Eigen::Quaternion<T> dq = q_p.cast<T>().conjugate() * q;
  if (dq.w() < T(0.0)) dq.coeffs() = -dq.coeffs();
  const Eigen::Matrix<T, 3, 1> rot = T(2.0) * dq.vec();
  const Eigen::Matrix<T, 3, 1> dt_w = t - t_p.cast<T>();
  const Eigen::Matrix<T, 3, 1> dt_b = q_p.cast<T>().conjugate() * dt_w;
  const Eigen::Matrix<T, 3, 1> planar(dt_w.x(), dt_w.y(), rot.z());
  const Eigen::Matrix<T, 3, 1> r = sqrt_info.cast<T>() * planar;
  residual[0] = r.x();
  residual[1] = r.y();
  residual[2] = r.z();
  residual[3] = dt_b.z() * T(inv_sigma_m);
  residual[4] = rot.x() * T(inv_sigma_rad);
  residual[5] = rot.y() * T(inv_sigma_rad);
  return true;
}

/// The vision-only baseline: OpenCV solvePnPRansac (iterative, from the prediction as the
/// extrinsic guess) on the observations' map points and left pixels. `visual` with at least
/// update.min_landmarks RANSAC inliers; the covariance is then the prediction's (PnP gives none).
PoseUpdateResult pnpPose(const StereoRig& rig,
                         const PoseWithCovariance& prediction,
                         const std::vector<LandmarkObservation>& observations,
                         const PoseUpdateOptions& update,
                         const PnpOptions& pnp);

/// Planar part of a 6-DoF pose: (x, y, yaw of the body x axis projected on the floor).
Pose2 toPose2(const Eigen::Isometry3d& T_w_b);

}  // namespace twocam::localization
