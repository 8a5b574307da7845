#pragma once
/// The one wheel-odometry noise model of TwoCam: how the error of the odometry grows with the
/// distance driven and the angle turned. The simulator's wheel model (sim/motion.h) draws its
/// random increment errors with randomIncrementSigma(); the landmark tracker's gates, the anchor
/// check and the refinement's weights (landmarks/landmark_model.h, landmarks/refine.h) and the
/// synthetic test stream use the same form. Derivation: docs/landmarks.md.
///
/// Per increment (ds [m], dyaw [rad]) the random part of the error has standard deviation
///   sigma_ds = trans_sigma_per_sqrt_m sqrt(|ds|),  sigma_dyaw = rot_sigma_per_sqrt_rad
///   sqrt(|dyaw|)
/// (a random walk: variances add along the path), plus systematic errors proportional to the
/// increment (wheel radius and wheel base errors). Accumulated over a path s and an absolute turn
/// theta, as the tracker assumes it (systematic parts add linearly, as they do not average out):
///   sigma_t   = a_t sqrt(s) + k_t s                      (translation error [m])
///   sigma_yaw = a_r sqrt(|theta|) + k_r |theta| + c_r s  (heading error [rad])

#include <cmath>

#include "common/status.h"

namespace twocam {

/// The five parameters of the model. Defaults: what the landmark tracker assumes, 1.5x the
/// office world's simulated noise, because the tracker does not know the robot's true noise and
/// a gate that is too narrow loses real landmarks.
struct OdometryNoise {
  /// Random translation error [m / sqrt(m)] of the distance driven (a_t). Office world: 0.02.
  double trans_sigma_per_sqrt_m = 0.03;
  /// Systematic relative error of the distance [-] (k_t, wheel radius error). Office world: 0.01.
  double trans_scale_sigma = 0.015;
  /// Random heading error [rad / sqrt(rad)] of the angle turned (a_r). Office world: 0.03.
  double rot_sigma_per_sqrt_rad = 0.045;
  /// Systematic relative heading error [-] (k_r, wheel base error). Office world: 0.01.
  double rot_scale_sigma = 0.015;
  /// Heading error accumulated per metre driven even without turning [rad / m] (c_r): unequal
  /// wheel radii make the robot curve slightly. Not in the simulated model; 2 mrad/m is typical.
  double rot_sigma_per_m = 0.002;

  /// Every field finite and in [0, 1] (larger values make every gate cover the image, and the
  /// pixel offsets they imply overflow the tracker's integer pixel ranges). Messages name the
  /// field prefixed with `prefix` (e.g. "landmarks.tracker.odometry_noise.").
  [[nodiscard]] Status validate(const char* prefix = "") const;
};

/// Standard deviation of the random error of one odometry increment: sigma_per_sqrt_unit
/// sqrt(|increment|) (the simulator's draw per increment, the synthetic stream's).
inline double randomIncrementSigma(double sigma_per_sqrt_unit, double increment) {
  return sigma_per_sqrt_unit * std::sqrt(std::abs(increment));
}

/// Standard deviations of the accumulated odometry error (see the file comment).
struct OdometryErrorSigma {
  double trans_m = 0.0;
  double yaw_rad = 0.0;
};

/// sigma_t and sigma_yaw after driving path_m (clamped at 0) and turning turn_rad (its absolute
/// value is used) since a reference pose.
/// Inline: the tracker evaluates it for every prediction.
inline OdometryErrorSigma accumulatedOdometrySigma(const OdometryNoise& noise,
                                                   double path_m,
                                                   double turn_rad) {
  const double s = path_m > 0.0 ? path_m : 0.0;  // std::max(0.0, path_m) without <algorithm>
  const double th = std::abs(turn_rad);
  OdometryErrorSigma out;
  out.trans_m = noise.trans_sigma_per_sqrt_m * std::sqrt(s) + noise.trans_scale_sigma * s;
  out.yaw_rad = noise.rot_sigma_per_sqrt_rad * std::sqrt(th) + noise.rot_scale_sigma * th +
                noise.rot_sigma_per_m * s;
  return out;
}

}  // namespace twocam
