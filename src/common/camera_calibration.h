#pragma once
/// Calibration of one raw (unrectified) camera, as dataset readers deliver it and the
/// rectifier consumes it. Lives in common so that io (which fills it) and frontend (which
/// rectifies with it) need not depend on each other.
///
/// Model: pinhole with radial-tangential (Brown-Conrady / OpenCV "plumb bob", 4 coefficients)
/// distortion. A point p_c = (x, y, z) in the camera optical frame (x right, y down, z forward)
/// projects to
///   x' = x / z, y' = y / z, r^2 = x'^2 + y'^2,
///   x'' = x' (1 + k1 r^2 + k2 r^4) + 2 p1 x' y' + p2 (r^2 + 2 x'^2),
///   y'' = y' (1 + k1 r^2 + k2 r^4) + p1 (r^2 + 2 y'^2) + 2 p2 x' y',
///   u = fx x'' + cx, v = fy y'' + cy.
/// Pixel convention: (0, 0) is the centre of the top-left pixel (OpenCV's and the project's
/// convention, docs/conventions.md). EuRoC's Kalibr calibrations use the same convention, so
/// their cu, cv are taken over unchanged.

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <sstream>

#include "common/status.h"

namespace twocam {

struct CameraCalibration {
  /// Image size [px].
  int width = 0;
  int height = 0;
  /// Focal lengths [px].
  double fx = 0.0;
  double fy = 0.0;
  /// Principal point [px], pixel-centre convention (see above).
  double cx = 0.0;
  double cy = 0.0;
  /// Radial-tangential distortion coefficients in OpenCV order: k1, k2, p1, p2.
  std::array<double, 4> radtan = {0.0, 0.0, 0.0, 0.0};
  /// Pose of the camera's optical frame in the robot body frame: p_b = T_b_c * p_c.
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  /// Nominal frame rate [Hz]; informational (0 when unknown).
  double rate_hz = 0.0;

  /// Checks sizes, positive finite focal lengths, finite principal point and distortion,
  /// and that T_b_c holds a proper rotation (orthonormal to 1e-6, determinant +1).
  [[nodiscard]] Status validate() const {
    std::ostringstream os;
    if (width <= 0 || height <= 0) {
      os << "camera image size " << width << "x" << height << " px; must be positive";
      return Status::error(os.str());
    }
    if (!(fx > 0.0) || !(fy > 0.0) || !std::isfinite(fx) || !std::isfinite(fy)) {
      os << "camera focal lengths fx = " << fx << ", fy = " << fy << " px; must be finite and > 0";
      return Status::error(os.str());
    }
    if (!std::isfinite(cx) || !std::isfinite(cy)) {
      os << "camera principal point (" << cx << ", " << cy << ") px is not finite";
      return Status::error(os.str());
    }
    for (double k : radtan) {
      if (!std::isfinite(k)) return Status::error("camera distortion coefficient is not finite");
    }
    const Eigen::Matrix3d R = T_b_c.linear();
    // Calibration files print ~10 significant digits; 1e-6 accepts that rounding and rejects
    // matrices that are not rotations at all.
    constexpr double kRotationTol = 1e-6;
    const double orthonormality_error =
        (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (!T_b_c.matrix().allFinite() || !(orthonormality_error < kRotationTol) ||
        !(R.determinant() > 0.0)) {
      os << "camera pose T_b_c is not a rigid transform (|R^T R - I|max = " << orthonormality_error
         << ", det R = " << R.determinant() << ")";
      return Status::error(os.str());
    }
    return Status::ok();
  }
};

}  // namespace twocam
