#pragma once
/// Multi-view triangulation of a confirmed landmark with Ceres, anchored: the landmark stays on
/// the ray of its anchor pixel (observations[0]) and its disparity there is estimated from the
/// disparities of all its observations, each predicted through the odometry poses relative to
/// the anchor frame, under a Huber loss. Columns and rows are left out on purpose, measured on
/// the office world (docs/landmarks.md): a heading error of the odometry shifts every column
/// alike, and rows are a weak depth cue whose corner-localisation bias moved refined depths by
/// 1-2 px of disparity (precision 91.5 % with rows, 98.6 % without). Keeping the ray fixed
/// means odometry drift can move the point along its anchor ray only.

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/rig.h"
#include "landmarks/landmark_database.h"

namespace twocam::landmarks {

struct RefineOptions {
  /// Disparity measurement sigma [px]: residuals are divided by it.
  double disparity_sigma_px = 0.5;
  /// Huber scale in sigmas [-].
  double huber = 1.0;
  /// Gauss-Newton iterations (a 3-parameter problem converges in a handful) [-].
  int max_iterations = 10;
};

enum class RefineResult { kOk, kTooFewObservations, kNoConvergence, kBehindCamera };

/// Refines p_w in place from the observations (at least 2). On anything but kOk, p_w is left
/// unchanged. rms_sigma (optional) receives the RMS normalised residual after refinement.
RefineResult refineLandmark(const StereoRig& rig,
                            const Eigen::Isometry3d& T_b_cl,
                            const std::vector<Observation>& observations,
                            const RefineOptions& options,
                            Eigen::Vector3d* p_w,
                            double* rms_sigma = nullptr);

}  // namespace twocam::landmarks
