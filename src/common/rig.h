#pragma once
/// The rectified stereo rig: shared pinhole intrinsics, baseline, and mounting on the robot.
/// Conventions (docs/conventions.md): camera optical frame x right, y down, z forward;
/// pixel (0, 0) is the centre of the top-left pixel; the right camera sits at +baseline
/// along the left camera's x axis; disparity d = u_left - u_right, depth Z = fx * B / d.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>

#include "common/status.h"

namespace twocam {

struct StereoRig {
  /// Image size [px].
  int width_px = 640;
  int height_px = 480;
  /// Focal lengths [px].
  double fx_px = 500.0;
  double fy_px = 500.0;
  /// Principal point [px], pixel-centre convention.
  double cx_px = 319.5;
  double cy_px = 239.5;
  /// Distance between the optical centres, right camera at +x of the left one [m].
  double baseline_m = 0.12;
  /// Pose of the left camera (optical frame) in the robot body frame.
  Eigen::Isometry3d T_b_cl = Eigen::Isometry3d::Identity();

  [[nodiscard]] Status validate() const;
  /// Pose of the right camera in the left camera frame: a pure translation of +baseline along x.
  [[nodiscard]] Eigen::Isometry3d T_cl_cr() const;
};

/// Projects a point given in the left camera frame to the left image.
/// Returns false when the point is not in front of the camera (z <= 0).
bool projectLeft(const StereoRig& rig, const Eigen::Vector3d& p_cl, Eigen::Vector2d* uv);

/// Triangulates a rectified stereo match in the left-camera frame.
/// Returns nullopt when disparity_px <= 0 (point at infinity or behind the rig).
std::optional<Eigen::Vector3d> triangulateRectified(const StereoRig& rig,
                                                    const Eigen::Vector2d& uv_left,
                                                    double disparity_px);

/// Camera optical frame (x right, y down, z forward) of a camera whose viewing direction
/// is given by yaw and pitch (pitch > 0 looks down) relative to the body's x axis, z up:
/// returns R_b_c.
Eigen::Matrix3d opticalRotationFromYawPitch(double yaw_rad, double pitch_rad);

}  // namespace twocam
