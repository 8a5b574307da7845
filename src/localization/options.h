#pragma once
/// Options of the visual pose correction (localization/pose_update.h). Model and defaults:
/// docs/localization.md.

#include <string>
#include <vector>

#include "common/status.h"

namespace twocam::localization {

/// Where a run's poses come from (`--localization`, config `localization.mode`).
enum class Mode {
  kOdometry,  ///< dead reckoning: the wheel-odometry pose as logged
  kPnp,       ///< vision only: OpenCV solvePnPRansac frame-to-map on the same associations
  kFused,     ///< odometry prediction corrected by the robust pose update (pose_update.h)
};
const char* modeName(Mode mode);
/// "odometry" | "pnp" | "fused"; an error lists them.
Status parseMode(const std::string& name, Mode* mode);

struct PoseUpdateOptions {
  /// Fewest confirmed landmarks observed in a frame for a visual correction [-]; with fewer the
  /// pose stays the odometry prediction and its covariance grows. Six observations give 18
  /// residuals for 6 unknowns, enough for the Huber loss to outvote one wrong association.
  int min_landmarks = 6;
  /// Standard deviation of an observed landmark's column and row [px] and disparity [px]. The
  /// tracker's pixel and disparity sigmas (landmarks.tracker), plus the error of the map point
  /// itself seen from another place, hence a little wider.
  double pixel_sigma_px = 1.0;
  double disparity_sigma_px = 1.0;
  /// Scale of the Cauchy loss on the normalised stereo residuals [sigma]. A redescending loss:
  /// a wrong association (a neighbouring corner, a periodic alias) is many sigma off and its pull
  /// falls as 1/r, where under a Huber loss it stays constant. On office (one loop) Huber at 2
  /// sigma gave ATE 0.162 m, worse than odometry's 0.122 m; Cauchy at 1 sigma 0.012 m
  /// (docs/localization.md).
  double cauchy_sigma = 1.0;
  /// Squared normalised residual (3 dof) above which an observation is an outlier: not counted
  /// as used and not in the covariance [-]. 11.34 = chi-square(3) 99 %.
  double inlier_chi2 = 11.34;
  /// Soft planar prior: per-frame standard deviation of the height change [m] and of the roll
  /// and pitch change [rad] relative to the prediction. Small for a robot on a floor; a car on
  /// a sloped road (KITTI) needs more.
  double planar_sigma_m = 0.005;
  double planar_sigma_rad = 0.005;
  /// Gauss-Newton iterations of the Ceres solve [-].
  int max_iterations = 10;
  /// Most observations in the solve [-]: with more, an evenly strided subset of them in the
  /// database's order (deterministic); the solve's cost is linear in them. 0 = all, the
  /// default: 200 made the office localisation stage 2.5x faster (1.7 against 4.2 ms median)
  /// but its ATE 0.023 m against 0.019 m (docs/experiments/2026-12-03-localization-gates.md).
  int max_observations = 0;

  /// Each field in range; messages are prefixed with `prefix` (e.g. "localization.").
  [[nodiscard]] Status validate(const char* prefix = "") const;
};

struct SlipTestOptions {
  /// Frames over which odometry's motion is compared with the visual estimates' [-].
  int window_frames = 3;
  /// Chi-square (3 dof) of that difference above which the window holds an odometry outlier
  /// [-]. 16.27 = chi-square(3) 99.9 %.
  double chi2 = 16.27;

  [[nodiscard]] Status validate(const char* prefix = "") const;
};

struct PnpOptions {
  /// RANSAC inlier threshold on the reprojection error [px] and iterations [-].
  double reprojection_px = 2.0;
  int iterations = 100;
  [[nodiscard]] Status validate(const char* prefix = "") const;
};

/// The `localization` section of the run config.
struct LocalizationOptions {
  /// Fused: measured better than odometry (ATE 0.10x-0.79x) and than pnp on every world
  /// (docs/localization.md); odometry reproduces dead reckoning.
  Mode mode = Mode::kFused;
  /// pnp, fused: confirmed landmarks are gated by the estimate's predicted covariance (never
  /// wider than the odometry gates; the odometry gates again when too few associate:
  /// LandmarkDatabase::setPredictionSigma). false: odometry gates, as in odometry mode.
  bool estimate_gates = true;
  PoseUpdateOptions update;
  SlipTestOptions slip;
  PnpOptions pnp;
  /// Messages name the key: "localization.update.min_landmarks = 1; must be in [3, 100000]".
  [[nodiscard]] Status validate() const;
};

}  // namespace twocam::localization
