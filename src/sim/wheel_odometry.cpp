#include "sim/wheel_odometry.h"

#include <cmath>

#include "common/odometry_noise.h"
#include "common/random.h"
#include "common/status.h"

namespace twocam::sim {

namespace {

double wrapAngle(double a) {
  a = std::remainder(a, 2.0 * M_PI);  // [-pi, pi]
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

/// Composes a body-frame displacement onto a pose (SE(2) product pose * delta).
Pose2 compose(const Pose2& pose, double dx_m, double dy_m, double dyaw_rad) {
  const double c = std::cos(pose.yaw_rad);
  const double s = std::sin(pose.yaw_rad);
  Pose2 out;
  out.x_m = pose.x_m + c * dx_m - s * dy_m;
  out.y_m = pose.y_m + s * dx_m + c * dy_m;
  out.yaw_rad = wrapAngle(pose.yaw_rad + dyaw_rad);
  return out;
}

}  // namespace

Pose2 integrateIncrement(const Pose2& pose, double ds_m, double dyaw_rad) {
  const double mean_yaw = pose.yaw_rad + 0.5 * dyaw_rad;
  Pose2 out;
  out.x_m = pose.x_m + ds_m * std::cos(mean_yaw);
  out.y_m = pose.y_m + ds_m * std::sin(mean_yaw);
  out.yaw_rad = wrapAngle(pose.yaw_rad + dyaw_rad);
  return out;
}

WheelOdometry::WheelOdometry(const OdometryNoiseSpec& noise, uint64_t seed, const Pose2& start)
    : noise_(noise),
      rng_(makeRng(seed, RandomStream::kOdometryNoise)),
      pose_(start),
      slip_applied_(noise.slips.size(), false) {
  TWOCAM_CHECK(noise_.scale_error > -1.0) << "scale_error = " << noise_.scale_error;
  TWOCAM_CHECK(noise_.wheel_base_error > -1.0) << "wheel_base_error = " << noise_.wheel_base_error;
  TWOCAM_CHECK(noise_.sigma_per_m >= 0.0 && noise_.sigma_per_rad >= 0.0)
      << "sigma_per_m = " << noise_.sigma_per_m << ", sigma_per_rad = " << noise_.sigma_per_rad;
}

void WheelOdometry::advance(double ds_m, double dyaw_rad, double t_end_s) {
  if (ds_m != 0.0 || dyaw_rad != 0.0) {
    // The random part: common/odometry_noise.h. No draw when a variance is zero, so noise-free
    // runs are exact and do not depend on the generator.
    double ds_odo = (1.0 + noise_.scale_error) * ds_m;
    double dyaw_odo = dyaw_rad / (1.0 + noise_.wheel_base_error);
    if (noise_.sigma_per_m > 0.0 && ds_m != 0.0) {
      ds_odo += randomIncrementSigma(noise_.sigma_per_m, ds_m) * unit_normal_(rng_);
    }
    if (noise_.sigma_per_rad > 0.0 && dyaw_rad != 0.0) {
      dyaw_odo += randomIncrementSigma(noise_.sigma_per_rad, dyaw_rad) * unit_normal_(rng_);
    }
    pose_ = integrateIncrement(pose_, ds_odo, dyaw_odo);
  }
  // Slips whose time lies before the end of this increment; slips at or before t = 0 land in
  // the first increment.
  for (size_t i = 0; i < noise_.slips.size(); ++i) {
    const SlipEvent& slip = noise_.slips[i];
    if (!slip_applied_[i] && slip.time_s <= t_end_s) {
      pose_ = compose(pose_, slip.dx_m, slip.dy_m, slip.dyaw_rad);
      slip_applied_[i] = true;
    }
  }
}

Pose2 planarPose(const Eigen::Isometry3d& T_w_b) {
  const Eigen::Vector3d x_axis = T_w_b.linear().col(0);
  Pose2 p;
  p.x_m = T_w_b.translation().x();
  p.y_m = T_w_b.translation().y();
  p.yaw_rad = std::atan2(x_axis.y(), x_axis.x());
  return p;
}

void planarIncrement(const Pose2& from, const Pose2& to, double* ds_m, double* dyaw_rad) {
  const double dyaw = wrapAngle(to.yaw_rad - from.yaw_rad);
  const double mean_yaw = from.yaw_rad + 0.5 * dyaw;
  *dyaw_rad = dyaw;
  *ds_m = (to.x_m - from.x_m) * std::cos(mean_yaw) + (to.y_m - from.y_m) * std::sin(mean_yaw);
}

std::vector<Pose2> syntheticOdometry(const std::vector<int64_t>& t_ns,
                                     const std::vector<Eigen::Isometry3d>& T_w_b,
                                     const OdometryNoiseSpec& noise,
                                     uint64_t seed) {
  TWOCAM_CHECK(t_ns.size() == T_w_b.size())
      << t_ns.size() << " time stamps but " << T_w_b.size() << " poses";
  std::vector<Pose2> out;
  if (t_ns.empty()) return out;
  out.reserve(t_ns.size());
  Pose2 truth_before = planarPose(T_w_b[0]);
  WheelOdometry odometry(noise, seed, truth_before);
  out.push_back(odometry.pose());
  for (size_t k = 1; k < t_ns.size(); ++k) {
    TWOCAM_CHECK(t_ns[k] >= t_ns[k - 1])
        << "time stamps decrease at " << k << ": " << t_ns[k - 1] << " then " << t_ns[k];
    const Pose2 truth = planarPose(T_w_b[k]);
    double ds = 0.0;
    double dyaw = 0.0;
    planarIncrement(truth_before, truth, &ds, &dyaw);
    // Division, not * 1e-9: exact for whole milliseconds, so a slip at 1.5 s lands on the frame
    // stamped 1.5 s after the first.
    odometry.advance(ds, dyaw, static_cast<double>(t_ns[k] - t_ns[0]) / 1e9);
    out.push_back(odometry.pose());
    truth_before = truth;
  }
  return out;
}

}  // namespace twocam::sim
