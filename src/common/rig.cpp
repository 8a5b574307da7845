#include "common/rig.h"

#include <cmath>
#include <sstream>

namespace twocam {

namespace {
Status fail(const std::string& what) { return Status::error(what); }
}  // namespace

Status StereoRig::validate() const {
  std::ostringstream os;
  if (width_px < 16 || height_px < 16) {
    os << "rig image size " << width_px << "x" << height_px << " px; must be at least 16x16";
    return fail(os.str());
  }
  if (!(fx_px > 0.0) || !(fy_px > 0.0) || !std::isfinite(fx_px) || !std::isfinite(fy_px)) {
    os << "rig focal lengths fx = " << fx_px << ", fy = " << fy_px << " px; must be > 0";
    return fail(os.str());
  }
  if (!std::isfinite(cx_px) || !std::isfinite(cy_px))
    return fail("rig principal point is not finite");
  if (!(baseline_m > 0.0) || !std::isfinite(baseline_m)) {
    os << "rig baseline_m = " << baseline_m << "; must be > 0";
    return fail(os.str());
  }
  return Status::ok();
}

Eigen::Isometry3d StereoRig::T_cl_cr() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(baseline_m, 0.0, 0.0);
  return T;
}

bool projectLeft(const StereoRig& rig, const Eigen::Vector3d& p_cl, Eigen::Vector2d* uv) {
  if (!(p_cl.z() > 0.0)) return false;
  const double inv_z = 1.0 / p_cl.z();
  (*uv) << rig.fx_px * p_cl.x() * inv_z + rig.cx_px, rig.fy_px * p_cl.y() * inv_z + rig.cy_px;
  return true;
}

std::optional<Eigen::Vector3d> triangulateRectified(const StereoRig& rig,
                                                    const Eigen::Vector2d& uv_left,
                                                    double disparity_px) {
  if (!(disparity_px > 0.0)) return std::nullopt;
  const double z = rig.fx_px * rig.baseline_m / disparity_px;
  return Eigen::Vector3d(
      (uv_left.x() - rig.cx_px) * z / rig.fx_px, (uv_left.y() - rig.cy_px) * z / rig.fy_px, z);
}

Eigen::Matrix3d opticalRotationFromYawPitch(double yaw_rad, double pitch_rad) {
  // Optical axes expressed in a body-aligned camera with no yaw or pitch:
  // z_c = forward (+x_b), x_c = right (-y_b), y_c = down (-z_b).
  Eigen::Matrix3d R_b_c0;
  R_b_c0.col(0) = Eigen::Vector3d(0, -1, 0);
  R_b_c0.col(1) = Eigen::Vector3d(0, 0, -1);
  R_b_c0.col(2) = Eigen::Vector3d(1, 0, 0);
  // Yaw about body z, then pitch about the camera's own (rotated) y_b axis; positive pitch
  // tilts the view down, i.e. a rotation about +y_b.
  const Eigen::Matrix3d R_yaw = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).matrix();
  const Eigen::Matrix3d R_pitch = Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitY()).matrix();
  return R_yaw * R_pitch * R_b_c0;
}

}  // namespace twocam
