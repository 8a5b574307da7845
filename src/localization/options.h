#pragma once
/// Options of the visual pose correction (localization/pose_update.h). Model and defaults:
/// docs/localization.md.

#include "common/status.h"

namespace twocam::localization {

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
  /// Huber threshold of the normalised stereo residuals [sigma].
  double huber_sigma = 2.0;
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

}  // namespace twocam::localization
