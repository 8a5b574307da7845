#pragma once
/// Stereo rectification of raw calibrated pairs (distorted, unaligned cameras, e.g. EuRoC)
/// into the project's rectified rig (common/rig.h): both cameras share fx, fy, cx, cy, the
/// rectified right camera sits at +baseline along the rectified left camera's x axis, image
/// rows are epipolar lines, disparity d = u_left - u_right >= 0.
///
/// The rectifying rotations and the common projection come from OpenCV's stereoRectify
/// (Bouguet's method: each camera is rotated half-way so that both image planes are coplanar
/// and parallel to the baseline) with CALIB_ZERO_DISPARITY, so both views share cx. The
/// per-pixel lookup tables are computed once (initUndistortRectifyMap, 16-bit fixed point with
/// 1/32 px sub-pixel steps) and every frame is remapped with bilinear interpolation.
///
/// Frames: R_rect_raw maps points from a raw camera's optical frame to its rectified one,
/// p_rect = R_rect_raw * p_raw (OpenCV's R1 for the left, R2 for the right camera). The rig's
/// T_b_cl is the pose of the RECTIFIED left camera in the body frame:
/// T_b_cl = T_b_c(raw left) * [R_rect_raw(left)^T | 0].
/// Pixels: (0, 0) is the centre of the top-left pixel throughout (OpenCV's convention).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <opencv2/core/mat.hpp>

#include "common/camera_calibration.h"
#include "common/image.h"
#include "common/rig.h"
#include "common/status.h"

namespace twocam::frontend {

struct RectifyOptions {
  /// Free scaling of the rectified views in [0, 1] (stereoRectify's alpha). 0 zooms in until
  /// every output pixel of both views comes from inside the raw images (no black borders; raw
  /// pixels near the edges are cut off); 1 keeps every raw pixel, leaving black (0) corners.
  /// Default 0: the stereo matchers would take black borders for texture.
  double alpha = 0.0;
  /// Size of the rectified images [px]; 0 means the raw image size (both 0 or both >= 16).
  int output_width_px = 0;
  int output_height_px = 0;
  [[nodiscard]] Status validate() const;
};

enum class StereoSide { kLeft, kRight };

/// Applies the radial-tangential model of common/camera_calibration.h to normalised image
/// coordinates (x/z, y/z) of an undistorted ray; k = {k1, k2, p1, p2}.
Eigen::Vector2d distortRadTan(const std::array<double, 4>& k,
                              const Eigen::Vector2d& xy_undistorted);

/// Inverts distortRadTan by Gauss-Newton from xy_distorted. Returns false when it does not
/// converge to 1e-12 within 50 iterations (far outside the calibrated field of view).
bool undistortRadTan(const std::array<double, 4>& k,
                     const Eigen::Vector2d& xy_distorted,
                     Eigen::Vector2d* xy_undistorted);

/// Precomputed rectification of one stereo pair. Immutable after create(); copies share the
/// lookup tables; rectify() is const and may run concurrently on different outputs.
class StereoRectifier {
 public:
  /// An empty rectifier: rectify() fails until create() has filled it.
  StereoRectifier() = default;

  /// Computes the rectified rig and the lookup tables for raw cameras `left` and `right`
  /// (both with pose in the same body frame). Fails on invalid calibrations or options,
  /// different raw image sizes, coincident cameras, a baseline that is mostly vertical, or a
  /// "right" camera that sits to the left of the "left" one (swap them).
  static Status create(const CameraCalibration& left,
                       const CameraCalibration& right,
                       const RectifyOptions& options,
                       StereoRectifier* out);

  /// True once create() has succeeded.
  [[nodiscard]] bool valid() const { return valid_; }
  /// The rectified rig (output size, shared intrinsics, baseline, rectified left pose).
  [[nodiscard]] const StereoRig& rig() const { return rig_; }
  /// Rotation from a raw camera frame to its rectified frame: p_rect = R_rect_raw * p_raw.
  [[nodiscard]] const Eigen::Matrix3d& R_rect_raw(StereoSide side) const;

  /// Rectifies one raw pair (sizes must equal the calibrations' raw size) into `left` and
  /// `right`, which are resized to the rig's size; their buffers are reused when already the
  /// right size. Outputs may alias inputs. Pixels that map outside the raw image become 0.
  Status rectify(const ImageU8& raw_left,
                 const ImageU8& raw_right,
                 ImageU8* left,
                 ImageU8* right) const;

  /// Maps a raw (distorted) pixel to its rectified pixel (undistort, rotate, project).
  /// Returns false when undistortion fails or the ray is not in front of the rectified camera.
  bool rectifyPixel(StereoSide side, const Eigen::Vector2d& raw_uv, Eigen::Vector2d* rect_uv) const;

  /// Maps a rectified pixel to the raw pixel it samples (closed form; the lookup tables hold
  /// this to 1/32 px). Returns false when the ray is not in front of the raw camera.
  bool rawPixel(StereoSide side, const Eigen::Vector2d& rect_uv, Eigen::Vector2d* raw_uv) const;

 private:
  struct View {
    CameraCalibration raw;
    Eigen::Matrix3d R_rect_raw = Eigen::Matrix3d::Identity();
    /// initUndistortRectifyMap output: integer source coordinates (CV_16SC2) and the index of
    /// the 1/32 px interpolation cell (CV_16UC1).
    cv::Mat map_xy;
    cv::Mat map_cell;
  };
  const View& view(StereoSide side) const { return side == StereoSide::kLeft ? left_ : right_; }

  bool valid_ = false;
  StereoRig rig_;
  View left_;
  View right_;
};

}  // namespace twocam::frontend
