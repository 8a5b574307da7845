#pragma once
/// Timestamped value structs exchanged between modules. The simulator and the log readers
/// emit exactly these, so the pipeline cannot tell a simulated run from a recorded one.

#include <Eigen/Geometry>
#include <cstdint>

#include "common/image.h"

namespace twocam {

/// One rectified stereo pair, 8-bit grey.
struct StereoFrame {
  int64_t t_ns = 0;
  ImageU8 left;
  ImageU8 right;
};

/// Planar pose of the robot body on the floor: x, y [m] and yaw [rad] about +z.
struct Pose2 {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

/// Accumulated wheel odometry: the body pose in the odometry frame at time t_ns.
/// The odometry frame coincides with the world frame at the start of a run.
struct OdometrySample {
  int64_t t_ns = 0;
  Pose2 pose;
};

/// Ground truth that travels beside a simulated frame; only evaluation code reads it.
struct GroundTruthFrame {
  int64_t t_ns = 0;
  /// True body pose in the world.
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  /// Depth along the left camera's optical axis [m] per left pixel; 0 = no surface.
  ImageF32 depth_left;
};

/// Lifts a planar pose to SE(3) on the z = 0 plane.
inline Eigen::Isometry3d toIsometry(const Pose2& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitZ()).matrix();
  T.translation() = Eigen::Vector3d(p.x_m, p.y_m, 0.0);
  return T;
}

}  // namespace twocam
