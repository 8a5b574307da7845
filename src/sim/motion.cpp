#include "sim/motion.h"

#include <algorithm>
#include <cmath>

#include "common/status.h"

namespace twocam::sim {

namespace {

/// Heading controller gain [1/s]: yaw rate = gain * heading error, then clamped. 2/s settles a
/// heading error in about 0.5 s, smooth at 15 Hz and far from the substep stability limit
/// (gain * dt << 1 with dt = 1 / (frame rate * substeps)).
constexpr double kHeadingGainPerS = 2.0;
/// Fraction of the cruise speed kept in the sharpest turns, so the robot always makes headway.
constexpr double kMinSpeedFraction = 0.15;
/// Braking distance before the final waypoint of a non-looping path, in units of
/// speed / min(heading gain, max yaw rate). With speed proportional to the distance d inside
/// it, the waypoint's bearing turns at v sin(e) / d <= min(gain, max rate) sin(e) cos(e), which
/// the heading controller out-turns for a factor >= 1: the robot homes in instead of orbiting.
constexpr double kBrakingDistanceFactor = 1.0;
/// Braking ends at this fraction of the cruise speed so the robot arrives in finite time.
constexpr double kMinApproachSpeedFraction = 0.1;
/// Distance at which the last waypoint of a non-looping path counts as reached [m]. Far
/// below one substep's travel: the last step is shortened to land on the waypoint.
constexpr double kArrivalToleranceM = 1e-6;

double wrapAngle(double a) {
  a = std::remainder(a, 2.0 * M_PI);  // [-pi, pi]
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

/// The waypoint the robot heads for first: the one after robot.start_waypoint (wrapping round),
/// skipping one that coincides with the start (a closed path's last waypoint repeating the
/// first; World::validate() rules out consecutive repeats otherwise).
size_t firstTarget(const RobotSpec& robot) {
  const size_t n = robot.waypoints.size();
  TWOCAM_CHECK(n >= 2) << "the robot path needs at least 2 waypoints, got " << n;
  TWOCAM_CHECK(startWaypointStatus(robot, robot.start_waypoint).isOk())
      << "robot.start_waypoint " << startWaypointStatus(robot, robot.start_waypoint).message();
  const size_t k = static_cast<size_t>(robot.start_waypoint);
  size_t target = (k + 1) % n;
  if (robot.waypoints[target] == robot.waypoints[k]) target = (target + 1) % n;
  TWOCAM_CHECK(robot.waypoints[target] != robot.waypoints[k])
      << "waypoints " << k << " and " << target << " coincide";
  return target;
}

/// The start pose: at waypoint start_waypoint, heading for firstTarget().
Pose2 startPose(const RobotSpec& robot) {
  const Eigen::Vector2d& p0 = robot.waypoints[static_cast<size_t>(robot.start_waypoint)];
  const Eigen::Vector2d d = robot.waypoints[firstTarget(robot)] - p0;
  Pose2 start;
  start.x_m = p0.x();
  start.y_m = p0.y();
  start.yaw_rad = std::atan2(d.y(), d.x());
  return start;
}

}  // namespace

MotionSimulator::MotionSimulator(const RobotSpec& robot,
                                 const OdometryNoiseSpec& noise,
                                 uint64_t seed,
                                 int64_t start_time_ns)
    : robot_(robot), start_time_ns_(start_time_ns), odometry_(noise, seed, startPose(robot)) {
  TWOCAM_CHECK(robot_.frame_rate_hz > 0.0) << "frame_rate_hz = " << robot_.frame_rate_hz;
  TWOCAM_CHECK(robot_.speed_mps >= 0.0) << "speed_mps = " << robot_.speed_mps;
  TWOCAM_CHECK(robot_.max_yaw_rate_rps > 0.0) << "max_yaw_rate_rps = " << robot_.max_yaw_rate_rps;

  target_waypoint_ = firstTarget(robot_);
  state_.t_ns = start_time_ns_;
  state_.true_pose = startPose(robot_);
  state_.odom_pose = odometry_.pose();
}

MotionSample MotionSimulator::next() {
  if (frame_index_ > 0) {
    // Substep boundaries are computed from integer counts so that they tile time exactly and
    // a slip at k / frame_rate_hz falls into the last substep of frame k.
    const double substep_rate_hz = robot_.frame_rate_hz * kSubstepsPerFrame;
    const int64_t first = static_cast<int64_t>(frame_index_ - 1) * kSubstepsPerFrame;
    for (int i = 0; i < kSubstepsPerFrame; ++i) {
      const double t_end_s = static_cast<double>(first + i + 1) / substep_rate_hz;
      substep(t_end_s - t_s_, t_end_s);
    }
  }
  state_.t_ns =
      start_time_ns_ + std::llround(static_cast<double>(frame_index_) * 1e9 / robot_.frame_rate_hz);
  ++frame_index_;
  return state_;
}

void MotionSimulator::substep(double dt_s, double t_end_s) {
  const size_t n = robot_.waypoints.size();
  Pose2& truth = state_.true_pose;

  // Waypoint switching. Bounded so a path whose waypoints all lie within the radius cannot spin.
  double ds = 0.0;
  double dyaw = 0.0;
  for (size_t guard = 0; !stopped_ && guard <= n; ++guard) {
    const bool last = target_waypoint_ + 1 == n;
    const Eigen::Vector2d to_target =
        robot_.waypoints[target_waypoint_] - Eigen::Vector2d(truth.x_m, truth.y_m);
    const double dist = to_target.norm();
    const double heading_error =
        wrapAngle(std::atan2(to_target.y(), to_target.x()) - truth.yaw_rad);
    const bool final_leg = last && !robot_.loop;
    if (final_leg) {
      // Arrived, or the waypoint is within the radius but abeam or behind: the robot missed it
      // by a little and would otherwise circle around it.
      if (dist <= kArrivalToleranceM ||
          (dist < robot_.waypoint_radius_m && std::abs(heading_error) >= 0.5 * M_PI)) {
        stopped_ = true;
        break;
      }
    } else if (dist < robot_.waypoint_radius_m) {
      target_waypoint_ = (target_waypoint_ + 1) % n;
      continue;
    }
    const double yaw_rate = std::clamp(
        kHeadingGainPerS * heading_error, -robot_.max_yaw_rate_rps, robot_.max_yaw_rate_rps);
    double speed = robot_.speed_mps * std::max(kMinSpeedFraction, std::cos(heading_error));
    if (final_leg) {
      // Brake on the final approach (see kBrakingDistanceFactor).
      const double braking_distance_m = kBrakingDistanceFactor * robot_.speed_mps /
                                        std::min(kHeadingGainPerS, robot_.max_yaw_rate_rps);
      speed *= std::clamp(dist / braking_distance_m, kMinApproachSpeedFraction, 1.0);
    }
    ds = speed * dt_s;
    dyaw = yaw_rate * dt_s;
    // Do not overshoot the final waypoint.
    if (final_leg) ds = std::min(ds, dist);
    break;
  }

  if (ds != 0.0 || dyaw != 0.0) {
    truth = integrateIncrement(truth, ds, dyaw);
    state_.true_distance_m += std::abs(ds);
    state_.true_turned_rad += std::abs(dyaw);
  }
  // Wheel odometry from the same increment, then the slips whose time lies in
  // (t_s_, t_end_s]; slips at or before t = 0 land in the first substep.
  odometry_.advance(ds, dyaw, t_end_s);
  state_.odom_pose = odometry_.pose();
  t_s_ = t_end_s;
}

}  // namespace twocam::sim
