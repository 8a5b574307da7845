#pragma once
/// Wheel odometry with the world file's error model (OdometryNoiseSpec, docs/simulator.md):
/// random walk, scale error, wheel-base error and slips, drawn from a seeded stream. One
/// implementation for both users, so that the model is literally the same code:
///   - the simulator (sim/motion.h) feeds it the true increments of its integration substeps;
///   - `twocam import-kitti --synthetic-odometry` feeds it the planar increments between
///     consecutive ground-truth poses of a recorded sequence (syntheticOdometry below).
/// The random walk's variance adds per increment (sigma^2 |ds| per increment), so the
/// accumulated statistics do not depend on how finely the motion is cut into increments.

#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <vector>

#include "common/frames.h"
#include "sim/world.h"

namespace twocam::sim {

/// Applies one wheel-odometry increment to a pose: ds along the mean heading
/// (midpoint rule), then the turn. Shared by the true and the odometry integration so that
/// noise-free odometry equals the truth exactly.
Pose2 integrateIncrement(const Pose2& pose, double ds_m, double dyaw_rad);

/// Accumulated wheel odometry driven by true motion increments.
/// Deterministic for a given seed: the noise draws from RandomStream::kOdometryNoise, one
/// N(0, 1) draw per non-zero distance and per non-zero turn (none when the sigma is zero, so
/// noise-free odometry is exact and independent of the generator).
class WheelOdometry {
 public:
  /// `noise` must satisfy OdometryNoiseSpec::validate() (checked: TWOCAM_CHECK). The odometry
  /// starts at `start` (the true pose at time 0).
  WheelOdometry(const OdometryNoiseSpec& noise, uint64_t seed, const Pose2& start);

  /// One true increment (ds_m along the mean heading, dyaw_rad) ending at time t_end_s since
  /// the start: the increment with the model's errors, then every slip not yet applied whose
  /// time_s <= t_end_s (composed in the body frame). A zero increment draws nothing but still
  /// applies due slips.
  void advance(double ds_m, double dyaw_rad, double t_end_s);

  /// The odometry pose after the increments so far.
  [[nodiscard]] const Pose2& pose() const { return pose_; }

 private:
  OdometryNoiseSpec noise_;
  std::mt19937_64 rng_;
  /// N(0, 1), scaled per draw; a member so its cached second value stays in the seeded sequence.
  std::normal_distribution<double> unit_normal_{0.0, 1.0};
  Pose2 pose_;
  std::vector<bool> slip_applied_;
};

/// Planar projection of a body pose: x, y of its origin and the heading of its x axis projected
/// onto the world's x-y plane (yaw about +z).
Pose2 planarPose(const Eigen::Isometry3d& T_w_b);

/// The increment integrateIncrement() turns `from` into `to` with, up to the part of the motion
/// it cannot express: dyaw = wrapped yaw difference, ds = the displacement projected onto the
/// mean heading (yaw_from + dyaw / 2); the lateral remainder is dropped (a wheeled robot does
/// not move sideways). Exact for motion made by integrateIncrement.
void planarIncrement(const Pose2& from, const Pose2& to, double* ds_m, double* dyaw_rad);

/// Synthetic wheel odometry along a recorded trajectory: frame k's odometry pose from the
/// planar increments between the consecutive ground-truth poses T_w_b[k-1], T_w_b[k], with the
/// error model of `noise` (slip times count from t_ns[0]). Frame 0's odometry is the planar
/// ground-truth pose of frame 0. Sizes of t_ns and T_w_b must agree (TWOCAM_CHECK), t_ns must
/// not decrease.
std::vector<Pose2> syntheticOdometry(const std::vector<int64_t>& t_ns,
                                     const std::vector<Eigen::Isometry3d>& T_w_b,
                                     const OdometryNoiseSpec& noise,
                                     uint64_t seed);

}  // namespace twocam::sim
