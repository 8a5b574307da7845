#pragma once
/// Trajectory error (docs/conventions.md "Trajectories"): absolute trajectory error with no
/// alignment beyond the shared start pose (the odometry frame equals the world frame at the first
/// frame, so the tracks are compared as they are).

#include <cstdint>
#include <vector>

#include "common/status.h"
#include "io/trajectory.h"

namespace twocam::eval {

/// Root mean square of the position difference [m] between poses with equal time stamps.
/// Errors: different lengths, a time stamp that differs at the same index, empty tracks.
Status ateRmseM(const std::vector<io::TimedPose>& estimate,
                const std::vector<io::TimedPose>& truth,
                double* rmse_m);

/// Relative pose error over segments of true travel (KITTI's odometry metric, METRICS.md
/// trajectory.rpe_*): for every pose i, j is the first later pose with at least segment_m of
/// true path between them; the error is (T_true_i^-1 T_true_j)^-1 (T_est_i^-1 T_est_j), its
/// translation and rotation angle divided by segment_m, averaged over all pairs.
struct RelativePoseError {
  double trans_pct = 0.0;      ///< mean translation error [% of segment_m]; NaN without pairs
  double rot_deg_per_m = 0.0;  ///< mean rotation error [deg / m]; NaN without pairs
  int64_t pairs = 0;           ///< segments measured (0 when the path is shorter than one)
};

/// Errors as ateRmseM (same length and time stamps), and segment_m not positive.
Status relativePoseError(const std::vector<io::TimedPose>& estimate,
                         const std::vector<io::TimedPose>& truth,
                         double segment_m,
                         RelativePoseError* rpe);

}  // namespace twocam::eval
