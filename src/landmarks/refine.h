#pragma once
/// Multi-view triangulation of a confirmed landmark with Ceres (its TinySolver), anchored: the
/// landmark stays on the ray of its anchor pixel (observations[0]) and its disparity there is
/// estimated from the disparities of all its observations, each predicted through the odometry
/// poses relative to the anchor frame, under a Huber loss. Columns and rows are left out on
/// purpose, measured on the office world (docs/landmarks.md): a heading error of the odometry
/// shifts every column alike, and rows are a weak depth cue whose corner-localisation bias moved
/// refined depths by 1-2 px of disparity (precision 91.5 % with rows, 98.6 % without). Keeping the
/// ray fixed means odometry drift can move the point along its anchor ray only.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "common/rig.h"
#include "landmarks/landmark_database.h"

namespace twocam::landmarks {

struct RefineOptions {
  /// Disparity measurement sigma [px]: residuals are divided by it.
  double disparity_sigma_px = 0.5;
  /// Huber scale in sigmas [-].
  double huber = 1.0;
  /// Levenberg-Marquardt iterations (one parameter: it converges in a handful) [-].
  int max_iterations = 10;
  /// Weigh each observation by its odometry uncertainty relative to the anchor frame: its
  /// sigma becomes sqrt(disparity_sigma^2 + sigma_odo^2), sigma_odo the disparity error that
  /// the odometry noise model (noise_model's odometry_noise, predictionSigma()) expects after
  /// the straight-line distance and the heading change between the two odometry poses, plus
  /// the heading error's effect on depth (d |u - cx| / fx sigma_yaw). Without it, observations
  /// from metres away count as much as the anchor's neighbours, and odometry drift pulled
  /// refined disparities 1-2 px off on the office world (docs/landmarks.md).
  bool weight_by_odometry = true;
  /// Largest move of the anchor disparity the refinement may make, in disparity sigmas [-]:
  /// a refined value farther from the anchor's own measurement than this is rejected
  /// (kDisagreesWithAnchor, p_w unchanged). The anchor pixel is where the landmark is judged;
  /// observations that disagree with it by more than 1 sigma (0.5 px) are more likely to carry
  /// odometry drift or a neighbouring corner than to correct it (office world: 24 of 38
  /// wrong confirmed landmarks had a good anchor and a refinement pulled 1-2 px off). 2 sigma
  /// until 2026-12-02: with verification by summed evidence (more and longer tracks), 70 of the
  /// 106 wrong landmarks of office at three times the world's odometry noise (38 of 59 at x1)
  /// had a good anchor match and a refinement that moved them off it; at 1 sigma 71 (x3) and
  /// 48 (x1) are wrong, 21 and 18 of them with a good anchor (docs/landmarks.md,
  /// "Verification").
  double max_anchor_shift_sigmas = 1.0;
  /// Noise model for weight_by_odometry (its odometry_noise and sigma fields are used).
  TrackerOptions noise_model;
};

enum class RefineResult {
  kOk,
  kTooFewObservations,
  kNoConvergence,
  kBehindCamera,
  kDisagreesWithAnchor
};

/// Refines p_w in place from the observations (at least 2). On anything but kOk, p_w is left
/// unchanged. rms_sigma (optional) receives the RMS normalised residual after refinement.
RefineResult refineLandmark(const StereoRig& rig,
                            const Eigen::Isometry3d& T_b_cl,
                            const std::vector<Observation>& observations,
                            const RefineOptions& options,
                            Eigen::Vector3d* p_w,
                            double* rms_sigma = nullptr);

}  // namespace twocam::landmarks
