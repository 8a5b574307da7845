#pragma once
/// Multi-view triangulation of a confirmed landmark with Ceres: the position in the odometry
/// world frame that best explains all its stereo observations (u, v, d), each predicted through
/// the odometry pose of its frame, under a Huber loss (odometry drift and a few wrong
/// associations must not drag the point).

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/rig.h"
#include "landmarks/landmark_database.h"

namespace twocam::landmarks {

struct RefineOptions {
  /// Measurement sigmas [px]: residuals are divided by them.
  double pixel_sigma_px = 0.5;
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
