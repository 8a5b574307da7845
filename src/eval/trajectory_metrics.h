#pragma once
/// Trajectory error (docs/conventions.md "Trajectories"): absolute trajectory error with no
/// alignment beyond the shared start pose (the odometry frame equals the world frame at the first
/// frame, so the tracks are compared as they are).

#include <vector>

#include "common/status.h"
#include "io/trajectory.h"

namespace twocam::eval {

/// Root mean square of the position difference [m] between poses with equal time stamps.
/// Errors: different lengths, a time stamp that differs at the same index, empty tracks.
Status ateRmseM(const std::vector<io::TimedPose>& estimate,
                const std::vector<io::TimedPose>& truth,
                double* rmse_m);

}  // namespace twocam::eval
