#pragma once
/// Reader for KITTI odometry sequence folders (Geiger et al., CVPR 2012), the layout of the
/// "data_odometry_gray" download with its ground truth copied in:
///
///   image_0/ or image_l/   left grey images 000000.png, 000001.png, ... (rectified)
///   image_1/ or image_r/   right grey images, same names
///   calib.txt              3x4 projection matrices of the rectified cameras, row-major:
///                          "P0: p00 p01 ... p23" then "P1: ..." (P2, P3, Tr and other named
///                          lines are ignored), or the same 12 numbers per line without the
///                          names (first line P0, second P1, further lines ignored)
///   poses.txt              optional ground truth: one line per image pair, 12 numbers, the
///                          3x4 row-major pose T_w_cam0 of the left camera in the first
///                          camera's frame (KITTI's camera axes: x right, y down, z forward)
///   times.txt              optional: one time stamp per pair [s]; without it 10 Hz is
///                          assumed (t = k * 100 ms, KITTI's camera rate)
///
/// Camera 0 is the left and camera 1 the right camera (KITTI's grey pair). The images are
/// already rectified: the rig has zero distortion, fx = P0[0][0], fy = P0[1][1],
/// cx = P0[0][2], cy = P0[1][2] (KITTI's 0-based pixel coordinates, as TwoCam's, copied
/// unchanged) and baseline = -P1[0][3] / P1[0][0].
///
/// Mounting (KITTI gives no body frame): the body frame b sits at the left camera's optical
/// centre (camera height 0), x forward along the optical axis, y left, z up
/// (T_b_cl = opticalRotationFromYawPitch(0, 0), no translation). KITTI's cam0 is about 1.65 m
/// above the road, so the road lies near z = -1.65 m in TwoCam's world. Ground truth is the
/// body pose in the world = the body frame of the first image:
///   T_w_b(k) = T_b_cl * T_cam0w(0) * T_w_cam0(k) * T_b_cl^-1,  T_w_b(0) = identity.
/// Conventions: docs/conventions.md; format notes: docs/recorded_data.md.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.h"
#include "common/status.h"

namespace twocam::io {

/// KITTI's camera rate when a sequence has no times.txt [Hz].
inline constexpr double kKittiFrameRateHz = 10.0;

/// The mount of the left camera on the body for KITTI sequences (see the file comment).
Eigen::Isometry3d kittiBodyFromLeftCamera();

/// Rectified stereo calibration of a KITTI calib.txt (both forms, see the file comment) for
/// images of width_px x height_px. Fails, naming the file and the line, on a line that is not a
/// name and 12 numbers, on a missing P0 or P1, on P0 or P1 that is not a rectified projection
/// (zero skew, [0 0 1 0] last row, P0's last column zero, P1 with P0's intrinsics) and on a
/// baseline that is not positive (the right camera must be at +x of the left one).
/// rig->T_b_cl = kittiBodyFromLeftCamera().
Status loadKittiCalibration(const std::string& calib_txt,
                            int width_px,
                            int height_px,
                            StereoRig* rig);

/// Poses of KITTI's poses.txt (T_w_cam0 per line, camera axes). Blank lines (a missing final
/// newline, a trailing empty line) are skipped; every other line must hold 12 finite numbers
/// with an orthonormal rotation (to 1e-6: the files print ~9 digits; re-orthonormalised on
/// load). Errors name the file and the line.
Status loadKittiPoses(const std::string& poses_txt, std::vector<Eigen::Isometry3d>* T_w_cam0);

/// Time stamps of KITTI's times.txt [s] converted to ns; one finite, non-negative number per
/// non-blank line, strictly increasing. Errors name the file and the line.
Status loadKittiTimes(const std::string& times_txt, std::vector<int64_t>* t_ns);

/// Body poses in TwoCam's conventions from KITTI's camera poses (formula in the file comment):
/// the first one is the identity.
std::vector<Eigen::Isometry3d> kittiBodyPoses(const std::vector<Eigen::Isometry3d>& T_w_cam0,
                                              const Eigen::Isometry3d& T_b_cl);

struct KittiReadOptions {
  /// Read at most this many image pairs (the first ones); all when unset. poses.txt and
  /// times.txt must then hold at least this many lines instead of exactly one per pair.
  std::optional<int> max_frames;
  [[nodiscard]] Status validate() const;
};

/// A KITTI sequence ready for import: image paths, rig, time stamps and ground truth.
struct KittiSequence {
  /// The folder as the caller named it, and the image folders found in it.
  std::string dir;
  std::string left_dir;
  std::string right_dir;
  /// Image pairs in the folder (before max_frames).
  int pairs_available = 0;
  /// One entry per pair read (min(max_frames, pairs_available)).
  std::vector<std::string> left_paths;
  std::vector<std::string> right_paths;
  std::vector<int64_t> t_ns;
  /// True when t_ns came from times.txt, false for the 10 Hz default.
  bool has_times = false;
  /// Ground-truth body poses T_w_b (kittiBodyPoses); empty when the folder has no poses.txt.
  std::vector<Eigen::Isometry3d> T_w_b;
  /// Rectified rig; image size from the first left image.
  StereoRig rig;
};

/// Reads a KITTI sequence folder. Fails with a message naming the path as the caller gave it
/// when: the folder does not exist; image_0|image_l or image_1|image_r is missing (or both
/// spellings of one are present); the image folders hold no PNG images; images are not named
/// consecutively 000000.png, 000001.png, ... (a missing image names the first absent file);
/// left and right image names differ (names the image without a partner); calib.txt is missing
/// or bad; poses.txt or times.txt has a bad line or a line count other than the number of pairs
/// (at least max_frames lines with max_frames set: the message names the file and both
/// numbers). Images are not decoded, except the first left one for the image size.
Status loadKittiSequence(const std::string& dir,
                         KittiSequence* sequence,
                         const KittiReadOptions& options = KittiReadOptions());

}  // namespace twocam::io
