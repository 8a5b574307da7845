#pragma once
/// True robot motion (differential drive following waypoints with smooth turns) and the noisy
/// wheel odometry it produces. Model and parameters: docs/simulator.md.

#include <cstdint>

#include "common/frames.h"
#include "sim/wheel_odometry.h"
#include "sim/world.h"

namespace twocam::sim {

/// One frame of simulated motion.
struct MotionSample {
  int64_t t_ns = 0;
  /// True body pose in the world.
  Pose2 true_pose;
  /// Accumulated wheel odometry; equals true_pose at the first frame.
  Pose2 odom_pose;
  /// True distance travelled and angle turned (absolute) since the start [m], [rad].
  double true_distance_m = 0.0;
  double true_turned_rad = 0.0;
};

/// Steps a unicycle through the waypoints, from robot.start_waypoint on, at the frame rate (with
/// kSubstepsPerFrame internal integration steps per frame) and integrates wheel odometry with the
/// configured errors (sim/wheel_odometry.h, fed the true increment of every substep). Deterministic
/// for a given seed: the odometry noise draws from RandomStream::kOdometryNoise.
class MotionSimulator {
 public:
  static constexpr int kSubstepsPerFrame = 10;

  MotionSimulator(const RobotSpec& robot,
                  const OdometryNoiseSpec& noise,
                  uint64_t seed,
                  int64_t start_time_ns);

  /// Returns frame k (k = 0, 1, ...): frame 0 is the start pose at start_time_ns.
  MotionSample next();

 private:
  void substep(double dt_s, double t_end_s);

  RobotSpec robot_;
  int64_t start_time_ns_;
  int frame_index_ = 0;
  size_t target_waypoint_ = 1;
  bool stopped_ = false;
  double t_s_ = 0.0;
  MotionSample state_;
  WheelOdometry odometry_;
};

}  // namespace twocam::sim
