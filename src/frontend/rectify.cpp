#include "frontend/rectify.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <utility>

#include "frontend/cv_interop.h"

namespace twocam::frontend {

namespace {

cv::Mat cameraMatrix(const CameraCalibration& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0);
}

cv::Mat distortion(const CameraCalibration& c) {
  return (cv::Mat_<double>(1, 4) << c.radtan[0], c.radtan[1], c.radtan[2], c.radtan[3]);
}

cv::Mat toCv(const Eigen::Matrix3d& m) {
  cv::Mat out(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.at<double>(r, c) = m(r, c);
  return out;
}

Eigen::Matrix3d toEigen3(const cv::Mat& m) {
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = m.at<double>(r, c);
  return out;
}

// Remaps into `out`, reusing its buffer when it already has the right size.
void remapInto(const ImageU8& raw, const cv::Mat& map_xy, const cv::Mat& map_cell, ImageU8* out) {
  if (out->width != map_xy.cols || out->height != map_xy.rows) {
    *out = ImageU8(map_xy.cols, map_xy.rows);
  }
  cv::Mat dst = asMat(*out);
  const uint8_t* const buffer = out->data.data();
  cv::remap(
      asMat(raw), dst, map_xy, map_cell, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  TWOCAM_CHECK(dst.data == buffer) << "cv::remap reallocated a correctly sized output";
}

}  // namespace

Status RectifyOptions::validate() const {
  std::ostringstream os;
  if (!(alpha >= 0.0 && alpha <= 1.0)) {
    os << "alpha = " << alpha << "; must be in [0, 1]";
    return Status::error(os.str());
  }
  const bool both_zero = output_width_px == 0 && output_height_px == 0;
  // Sizes below 16 px are rejected by StereoRig::validate; above 2^15 the 16-bit maps overflow.
  constexpr int kMinSizePx = 16;
  constexpr int kMaxSizePx = 32767;
  const bool both_valid = output_width_px >= kMinSizePx && output_height_px >= kMinSizePx &&
                          output_width_px <= kMaxSizePx && output_height_px <= kMaxSizePx;
  if (!both_zero && !both_valid) {
    os << "output size " << output_width_px << "x" << output_height_px
       << " px; must be 0x0 (raw size) or both in [" << kMinSizePx << ", " << kMaxSizePx << "]";
    return Status::error(os.str());
  }
  return Status::ok();
}

Eigen::Vector2d distortRadTan(const std::array<double, 4>& k, const Eigen::Vector2d& xy) {
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k[0] + r2 * k[1]);
  return {x * radial + 2.0 * k[2] * x * y + k[3] * (r2 + 2.0 * x * x),
          y * radial + k[2] * (r2 + 2.0 * y * y) + 2.0 * k[3] * x * y};
}

bool undistortRadTan(const std::array<double, 4>& k,
                     const Eigen::Vector2d& xy_distorted,
                     Eigen::Vector2d* xy_undistorted) {
  constexpr int kMaxIterations = 50;
  // Normalised coordinates are O(1); 1e-12 is ~1e-9 px at any practical focal length.
  constexpr double kStepTol = 1e-12;
  Eigen::Vector2d xy = xy_distorted;
  for (int it = 0; it < kMaxIterations; ++it) {
    const double x = xy.x();
    const double y = xy.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k[0] + r2 * k[1]);
    // d radial / d x = 2 x (k1 + 2 k2 r^2), likewise for y.
    const double d_radial_d_r2 = k[0] + 2.0 * k[1] * r2;
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2.0 * x * x * d_radial_d_r2 + 2.0 * k[2] * y + 6.0 * k[3] * x;
    J(0, 1) = 2.0 * x * y * d_radial_d_r2 + 2.0 * k[2] * x + 2.0 * k[3] * y;
    J(1, 0) = 2.0 * x * y * d_radial_d_r2 + 2.0 * k[2] * x + 2.0 * k[3] * y;
    J(1, 1) = radial + 2.0 * y * y * d_radial_d_r2 + 6.0 * k[2] * y + 2.0 * k[3] * x;
    const double det = J.determinant();
    if (!(std::abs(det) > 1e-12)) return false;
    const Eigen::Vector2d step = J.inverse() * (distortRadTan(k, xy) - xy_distorted);
    xy -= step;
    if (!xy.allFinite()) return false;
    if (step.norm() < kStepTol) {
      *xy_undistorted = xy;
      return true;
    }
  }
  return false;
}

Status StereoRectifier::create(const CameraCalibration& left,
                               const CameraCalibration& right,
                               const RectifyOptions& options,
                               StereoRectifier* out) {
  if (out == nullptr) return Status::error("StereoRectifier::create: null output");
  if (Status s = options.validate(); !s) return Status::error("RectifyOptions: " + s.message());
  if (Status s = left.validate(); !s) return Status::error("left camera: " + s.message());
  if (Status s = right.validate(); !s) return Status::error("right camera: " + s.message());
  std::ostringstream os;
  if (left.width != right.width || left.height != right.height) {
    os << "raw image sizes differ: left " << left.width << "x" << left.height << " px, right "
       << right.width << "x" << right.height << " px";
    return Status::error(os.str());
  }
  const cv::Size raw_size(left.width, left.height);
  const cv::Size out_size = options.output_width_px == 0
                                ? raw_size
                                : cv::Size(options.output_width_px, options.output_height_px);

  // OpenCV wants the motion from camera 1 to camera 2 coordinates: p_cr = R p_cl + T.
  const Eigen::Isometry3d T_cr_cl = right.T_b_c.inverse() * left.T_b_c;
  const double distance_m = T_cr_cl.translation().norm();
  // Below 1 mm the epipolar geometry is meaningless for metre-scale scenes.
  constexpr double kMinBaselineM = 1e-3;
  if (!(distance_m >= kMinBaselineM)) {
    os << "camera centres are " << distance_m << " m apart; need >= " << kMinBaselineM << " m";
    return Status::error(os.str());
  }
  const cv::Mat R = toCv(T_cr_cl.rotation());
  const cv::Mat T = (cv::Mat_<double>(3, 1) << T_cr_cl.translation().x(),
                     T_cr_cl.translation().y(),
                     T_cr_cl.translation().z());
  cv::Mat R1, R2, P1, P2, Q;
  try {
    cv::stereoRectify(cameraMatrix(left),
                      distortion(left),
                      cameraMatrix(right),
                      distortion(right),
                      raw_size,
                      R,
                      T,
                      R1,
                      R2,
                      P1,
                      P2,
                      Q,
                      cv::CALIB_ZERO_DISPARITY,
                      options.alpha,
                      out_size);
  } catch (const cv::Exception& e) {
    return Status::error(std::string("cv::stereoRectify failed: ") + e.err);
  }

  // Horizontal rig: P2 = [f 0 cx -f*B; 0 f cy 0; 0 0 1 0] with B > 0 when the right camera is
  // at +x of the left one. stereoRectify picks a vertical layout (P2(1,3) != 0) when |t_y| > |t_x|.
  const double f = P1.at<double>(0, 0);
  const double tx = P2.at<double>(0, 3);
  const double ty = P2.at<double>(1, 3);
  if (std::abs(ty) > std::abs(tx)) {
    os << "the baseline is mostly vertical (OpenCV P2 = [.. " << tx << "; .. " << ty
       << "]); the rig needs side-by-side cameras";
    return Status::error(os.str());
  }
  if (!(tx < 0.0)) {
    os << "the right camera lies to the LEFT of the left camera (rectified baseline " << -tx / f
       << " m); swap the cameras";
    return Status::error(os.str());
  }

  StereoRectifier result;
  result.rig_.width_px = out_size.width;
  result.rig_.height_px = out_size.height;
  result.rig_.fx_px = f;
  result.rig_.fy_px = P1.at<double>(1, 1);
  result.rig_.cx_px = P1.at<double>(0, 2);
  result.rig_.cy_px = P1.at<double>(1, 2);
  result.rig_.baseline_m = -tx / f;
  result.left_.raw = left;
  result.right_.raw = right;
  result.left_.R_rect_raw = toEigen3(R1);
  result.right_.R_rect_raw = toEigen3(R2);
  result.rig_.T_b_cl = left.T_b_c;
  result.rig_.T_b_cl.linear() = left.T_b_c.linear() * result.left_.R_rect_raw.transpose();
  // CALIB_ZERO_DISPARITY makes both views share the principal point; the rig relies on it.
  // The two are copies of one computed value, so they agree to rounding.
  constexpr double kSharedPrincipalPointTolPx = 1e-9;
  TWOCAM_CHECK(std::abs(P2.at<double>(0, 2) - P1.at<double>(0, 2)) < kSharedPrincipalPointTolPx &&
               std::abs(P2.at<double>(1, 2) - P1.at<double>(1, 2)) < kSharedPrincipalPointTolPx)
      << "stereoRectify returned different principal points despite CALIB_ZERO_DISPARITY";
  if (Status s = result.rig_.validate(); !s) {
    return Status::error("rectified rig is invalid (" + s.message() + ")");
  }

  try {
    cv::initUndistortRectifyMap(cameraMatrix(left),
                                distortion(left),
                                R1,
                                P1,
                                out_size,
                                CV_16SC2,
                                result.left_.map_xy,
                                result.left_.map_cell);
    cv::initUndistortRectifyMap(cameraMatrix(right),
                                distortion(right),
                                R2,
                                P2,
                                out_size,
                                CV_16SC2,
                                result.right_.map_xy,
                                result.right_.map_cell);
  } catch (const cv::Exception& e) {
    return Status::error(std::string("cv::initUndistortRectifyMap failed: ") + e.err);
  }
  result.valid_ = true;
  *out = std::move(result);
  return Status::ok();
}

const Eigen::Matrix3d& StereoRectifier::R_rect_raw(StereoSide side) const {
  return view(side).R_rect_raw;
}

Status StereoRectifier::rectify(const ImageU8& raw_left,
                                const ImageU8& raw_right,
                                ImageU8* left,
                                ImageU8* right) const {
  if (!valid_) return Status::error("StereoRectifier::rectify: rectifier was not created");
  if (left == nullptr || right == nullptr || left == right) {
    return Status::error("StereoRectifier::rectify: outputs must be two distinct non-null images");
  }
  const CameraCalibration& cal = left_.raw;
  for (const ImageU8* raw : {&raw_left, &raw_right}) {
    if (raw->width != cal.width || raw->height != cal.height ||
        raw->data.size() != static_cast<size_t>(cal.width) * cal.height) {
      std::ostringstream os;
      os << "StereoRectifier::rectify: " << (raw == &raw_left ? "left" : "right")
         << " raw image is " << raw->width << "x" << raw->height << " px (" << raw->data.size()
         << " pixels stored); the calibration expects " << cal.width << "x" << cal.height;
      return Status::error(os.str());
    }
  }
  // cv::remap cannot work in place: write aliased outputs through a temporary.
  const bool left_aliases = left == &raw_left || left == &raw_right;
  const bool right_aliases = right == &raw_left || right == &raw_right;
  ImageU8 left_tmp;
  ImageU8 right_tmp;
  remapInto(raw_left, left_.map_xy, left_.map_cell, left_aliases ? &left_tmp : left);
  remapInto(raw_right, right_.map_xy, right_.map_cell, right_aliases ? &right_tmp : right);
  if (left_aliases) *left = std::move(left_tmp);
  if (right_aliases) *right = std::move(right_tmp);
  return Status::ok();
}

bool StereoRectifier::rectifyPixel(StereoSide side,
                                   const Eigen::Vector2d& raw_uv,
                                   Eigen::Vector2d* rect_uv) const {
  if (!valid_) return false;
  const View& v = view(side);
  const Eigen::Vector2d xy_d((raw_uv.x() - v.raw.cx) / v.raw.fx,
                             (raw_uv.y() - v.raw.cy) / v.raw.fy);
  Eigen::Vector2d xy;
  if (!undistortRadTan(v.raw.radtan, xy_d, &xy)) return false;
  const Eigen::Vector3d p_rect = v.R_rect_raw * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
  if (!(p_rect.z() > 0.0)) return false;
  return projectLeft(rig_, p_rect, rect_uv);
}

bool StereoRectifier::rawPixel(StereoSide side,
                               const Eigen::Vector2d& rect_uv,
                               Eigen::Vector2d* raw_uv) const {
  if (!valid_) return false;
  const View& v = view(side);
  const Eigen::Vector3d ray_rect(
      (rect_uv.x() - rig_.cx_px) / rig_.fx_px, (rect_uv.y() - rig_.cy_px) / rig_.fy_px, 1.0);
  const Eigen::Vector3d p_raw = v.R_rect_raw.transpose() * ray_rect;
  if (!(p_raw.z() > 0.0)) return false;
  const Eigen::Vector2d xy_d = distortRadTan(v.raw.radtan, p_raw.head<2>() / p_raw.z());
  *raw_uv = Eigen::Vector2d(v.raw.fx * xy_d.x() + v.raw.cx, v.raw.fy * xy_d.y() + v.raw.cy);
  return true;
}

}  // namespace twocam::frontend
