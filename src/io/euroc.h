#pragma once
/// Reader for EuRoC MAV / ASL-format stereo folders (Burri et al., IJRR 2016):
///
///   mav0/cam0/sensor.yaml   left camera:  intrinsics [fu, fv, cu, cv], resolution [w, h],
///                           distortion_model radial-tangential, distortion_coefficients
///                           [k1, k2, p1, p2], T_BS (4x4 body-from-sensor), rate_hz
///   mav0/cam0/data.csv      "#timestamp [ns],filename", one image per line
///   mav0/cam0/data/*.png    raw (distorted, unrectified) 8-bit grey images
///   mav0/cam1/...           right camera, same layout
///
/// EuRoC names cam0 the left and cam1 the right camera of the VI-Sensor; this reader keeps that
/// assignment. The images are raw: rectify them with frontend::StereoRectifier.
///
/// Pixel convention: EuRoC's intrinsics come from Kalibr, whose corner extraction reports the
/// centre of the top-left pixel as (0, 0), like OpenCV and this project; cu, cv are copied into
/// CameraCalibration::cx, cy unchanged (no 0.5 shift).

#include <cstdint>
#include <string>
#include <vector>

#include "common/camera_calibration.h"
#include "common/status.h"

namespace twocam::io {

/// The calibration struct lives in common (frontend consumes it without linking io).
using CameraCalibration = ::twocam::CameraCalibration;

/// Reads one EuRoC camera sensor.yaml. Accepts OpenCV's "%YAML:1.0" header as EuRoC writes it,
/// a standard "%YAML 1.x" header, or none. Requires the keys resolution, intrinsics,
/// distortion_model (must be "radial-tangential"; "radtan" and "plumb_bob" are accepted as
/// synonyms), distortion_coefficients (4 numbers) and T_BS (rows: 4, cols: 4, data: 16 numbers,
/// last row 0 0 0 1, rotation orthonormal to 1e-6; it is re-orthonormalised on load).
/// camera_model, when present, must be "pinhole"; rate_hz is optional (0 when absent).
/// Errors name the file and the key.
Status loadEurocCamera(const std::string& sensor_yaml, CameraCalibration* calibration);

/// Reads mav0/cam0/sensor.yaml (left) and mav0/cam1/sensor.yaml (right) and checks that both
/// cameras have the same image size (a requirement of rectification).
Status loadEurocStereoCalibration(const std::string& mav0_dir,
                                  CameraCalibration* left,
                                  CameraCalibration* right);

/// Stereo frames present in both cameras, in increasing time order.
struct EurocStereoIndex {
  /// Time stamp of each pair: the left (cam0) image's time stamp [ns].
  std::vector<int64_t> t_ns;
  /// Image file paths (mav0_dir/camN/data/filename), one per pair.
  std::vector<std::string> left_paths;
  std::vector<std::string> right_paths;
  /// Time stamps that had no partner in the other camera and were dropped [ns].
  std::vector<int64_t> unmatched_left_t_ns;
  std::vector<int64_t> unmatched_right_t_ns;
};

struct EurocIndexOptions {
  /// Largest |t_left - t_right| for two images to form a pair [ns]. EuRoC's cameras are
  /// hardware-triggered and cam0/cam1 carry identical stamps, so the default is exact equality.
  int64_t max_pair_offset_ns = 0;
  [[nodiscard]] Status validate() const;
};

/// Reads mav0/cam0/data.csv and mav0/cam1/data.csv and pairs their images by time stamp.
/// Each data.csv line is "<t_ns>,<filename>"; lines starting with '#' and blank lines are
/// skipped, '\r' line ends are accepted. Fails (naming file and line) on malformed lines,
/// negative or non-increasing time stamps, and on a listed image file that does not exist.
/// Time stamps without a partner within max_pair_offset_ns are dropped from the pairs and
/// listed in unmatched_left_t_ns / unmatched_right_t_ns; fails when no pair remains.
Status loadEurocStereoIndex(const std::string& mav0_dir,
                            EurocStereoIndex* index,
                            const EurocIndexOptions& options = EurocIndexOptions());

}  // namespace twocam::io
