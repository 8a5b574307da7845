#pragma once
/// The slip test (docs/localization.md, "Slip test"): odometry's steps against the steps the
/// reference landmarks measured, over a short window, so that one noisy step is not a slip.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/frames.h"
#include "common/odometry_noise.h"
#include "localization/options.h"

namespace twocam::localization {

/// The covariance the slip test takes for a measured step: the fit's (`step_cov`), the previous
/// estimate's (`previous_cov`) and odometry's noise (odometryCovariance) over the motion the
/// references measured, the odometry `increment` corrected by `step`. Not over the increment:
/// a slip's own turn or distance is in it, and the noise of a motion that did not happen
/// would widen the test (a 1.5 degree slip on a straight reads as a 1.5 degree turn, whose
/// heading noise in the default model is 0.42 degree).
Eigen::Matrix3d stepCovariance(const OdometryNoise& noise,
                               const Pose2& increment,
                               const Pose2& step,
                               const Eigen::Matrix3d& previous_cov,
                               const Eigen::Matrix3d& step_cov);

/// The odometry error between two poses the reference landmarks measured: the planar
/// correction e with T_w_b_to = T_w_b_from * odometry_motion * e, odometry_motion the odometry
/// increment between the two frames (odometryIncrement). When a frame's measured step did not
/// correct the estimate (no visual pose: too few inliers), the next prediction still holds that
/// error and the next step measures it again; against the earlier measured pose each error
/// enters the slip test once (office_loops seed 5, frames 421-424 in a blank turn: steps of
/// -1.5, -2.0, -2.5 and -2.8 degrees, one heading error growing, summed as -3.5 degrees and
/// flagged).
Pose2 odometryError(const Pose2& T_w_b_from, const Pose2& odometry_motion, const Pose2& T_w_b_to);

/// The window of the last SlipTestOptions::window_frames measured steps. A frame whose step
/// was not measured (too few references matched: a blank turn) is left out, not a break in the
/// window: the next measured step is taken against the estimate that frame left, so it spans
/// the odometry since the last visual update, with that estimate's grown covariance in its own.
class SlipTest {
 public:
  explicit SlipTest(const SlipTestOptions& options);

  /// Adds the frame's measured step: `error` is the planar correction of the prediction the
  /// references measured (PoseSearchResult::step), `cov` its covariance with the odometry
  /// step's and the previous estimate's added. When the window's summed error exceeds
  /// options.chi2 (chi-square, 3 dof, with the summed covariances), the window's most
  /// inconsistent step is the slip: returns its frame, each frame at most once; else -1.
  int32_t add(int32_t frame, const Pose2& error, const Eigen::Matrix3d& cov);

 private:
  struct Entry {
    int32_t frame;
    Eigen::Vector3d error;  // (x [m], y [m], yaw [rad])
    Eigen::Matrix3d cov;
  };
  SlipTestOptions options_;
  std::vector<Entry> window_;  // oldest first
  int32_t last_slip_frame_ = -1;
};

}  // namespace twocam::localization
