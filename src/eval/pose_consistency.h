#pragma once
/// landmarks.true_pose_consistency (docs/conventions.md; logs with true poses but no true depth,
/// e.g. KITTI): the share of confirmed landmarks whose observations, triangulated together with
/// the true camera poses, leave an RMS residual of at most kConsistentRmsPx in (u, v, d). A real
/// point is consistent under the true motion; a spurious match that only the noisy odometry
/// explained is not.

#include <Eigen/Geometry>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "common/features.h"
#include "common/rig.h"
#include "landmarks/landmark.h"
#include "landmarks/landmark_database.h"

namespace twocam::eval {

/// METRICS.md: consistent when the RMS residual is at most 1 px.
constexpr double kConsistentRmsPx = 1.0;

/// One observation of a landmark: the left camera's true pose and the measured (u, v, d) [px].
struct PosedObservation {
  Eigen::Isometry3d T_w_cl_true = Eigen::Isometry3d::Identity();
  double u_px = 0.0, v_px = 0.0, d_px = 0.0;
};

/// RMS of the (u, v, d) residuals [px] of the point that fits the observations best (Gauss-Newton
/// from the first observation's triangulation). NaN for fewer than two observations or when the
/// point ends behind a camera.
[[nodiscard]] double trueTriangulationRmsPx(const StereoRig& rig,
                                            const std::vector<PosedObservation>& observations);

struct PoseConsistencyMetrics {
  int64_t judged = 0;      ///< confirmed landmarks with at least two observations
  int64_t consistent = 0;  ///< of those, RMS residual <= kConsistentRmsPx
  double fraction = 0.0;   ///< consistent / judged; NaN when none were judged
};

/// Collects every landmark's observations (up to max_observations: the first ones, which include
/// those that confirmed it) frame by frame with the true poses; judges the confirmed ones at the
/// end. Memory follows the database's: removed landmarks are forgotten.
class TruePoseConsistency {
 public:
  explicit TruePoseConsistency(const StereoRig& rig, int max_observations = 24)
      : rig_(rig), max_observations_(max_observations) {}

  /// The frame's hypotheses and the database's report for it (hypothesis_landmark_id,
  /// removed_ids), with the frame's true body pose.
  void addFrame(const StereoHypotheses& hyps,
                const landmarks::FrameReport& report,
                const Eigen::Isometry3d& T_w_b_true);

  [[nodiscard]] PoseConsistencyMetrics finish(const landmarks::LandmarkDatabase& db) const;
  [[nodiscard]] PoseConsistencyMetrics finish(const std::vector<landmarks::Landmark>& slots) const;

 private:
  StereoRig rig_;
  int max_observations_;
  std::unordered_map<uint64_t, std::vector<PosedObservation>> observations_;
};

}  // namespace twocam::eval
