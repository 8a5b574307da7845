#pragma once
/// MRPT rawlogs: writing simulated runs and reading stereo logs back.
///
/// Layout of a TwoCam rawlog (docs/rawlog_format.md): the "observations-only" rawlog format,
/// gzip-compressed (MRPT's readers open it transparently). Each frame is a run of observations
/// with the same time stamp, in this order:
///   - CObservationStereoImages, label "STEREO": rectified grey left/right images stored as
///     external PNG files in "<log stem>_Images/" (MRPT's external-image convention), with
///     intrinsics, baseline and the left camera's pose on the robot filled in;
///   - CObservationOdometry, label "ODOMETRY": accumulated wheel odometry (x, y, yaw); label
///     "ODOMETRY_SYNTHETIC" when the odometry was not measured but drawn from ground truth
///     (`twocam import-kitti --synthetic-odometry`), and the header comment then says how;
///   - ground truth, simulated logs only: CObservationRobotPose, label "GT_POSE" (true body
///     pose in the world) and CObservation3DRangeScan, label "GT_DEPTH" (left camera depth
///     image along the optical axis, uint16 with rangeUnits metres per unit).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/frames.h"
#include "common/rig.h"
#include "common/status.h"

namespace twocam::io {

inline constexpr const char* kStereoLabel = "STEREO";
inline constexpr const char* kOdometryLabel = "ODOMETRY";
/// Label of odometry that no wheel measured (drawn from ground truth with a noise model).
inline constexpr const char* kSyntheticOdometryLabel = "ODOMETRY_SYNTHETIC";
inline constexpr const char* kGtPoseLabel = "GT_POSE";
inline constexpr const char* kGtDepthLabel = "GT_DEPTH";

/// A staged output file or folder and the path it replaces.
struct StagedMove {
  std::string staged;
  std::string final_path;
};

/// Moves every staged path onto its final path, all or nothing: existing finals are first
/// renamed aside ("<final>.old"), then the staged paths renamed in; on any failure the moves
/// done so far are undone and the Status names the path. The set-aside copies are removed at
/// the end. Renames only: staged and final paths must be on one file system (same folder).
Status commitStaged(const std::vector<StagedMove>& moves);

struct RawlogWriterOptions {
  /// zlib level of the rawlog stream, 0 (none) to 9; 1 is fast and shrinks depth images ~3x.
  /// Limits (validate()): depth_unit_m in [0, 1], max_depth_m in (0, kMaxLogCoordinateM].
  int gzip_level = 1;
  /// Depth quantisation of the ground-truth depth image [m per unit]. 0 = choose the finest
  /// unit that still represents max_depth_m in 16 bits.
  double depth_unit_m = 0.0;
  /// Largest depth the ground-truth image must represent [m] (used when depth_unit_m = 0).
  double max_depth_m = 60.0;
  /// Empty: the odometry written is measured (or simulated wheel odometry). Otherwise the
  /// odometry is synthetic and this one-line note says how it was made; the observations are
  /// labelled kSyntheticOdometryLabel and the note goes into the log's header, so that readers
  /// (RawlogReader::syntheticOdometry) and people can tell.
  std::string synthetic_odometry;
  [[nodiscard]] Status validate() const;
};

/// The depth unit chosen for a given options struct [m]: at least 0.1 mm.
double depthUnit(const RawlogWriterOptions& options);

/// Writes a rawlog frame by frame. Output goes to "<path>.partial" and
/// "<stem>_Images.partial/" and is renamed into place by finish(), so an interrupted or failed
/// run never leaves a log that looks complete. Destroying an unfinished writer removes its
/// partial files.
class RawlogWriter {
 public:
  static Status open(const std::string& path,
                     const StereoRig& rig,
                     const RawlogWriterOptions& options,
                     std::unique_ptr<RawlogWriter>* out);
  ~RawlogWriter();
  RawlogWriter(const RawlogWriter&) = delete;
  RawlogWriter& operator=(const RawlogWriter&) = delete;

  /// Appends one frame. odometry and ground_truth may be null.
  Status write(const StereoFrame& stereo,
               const OdometrySample* odometry,
               const GroundTruthFrame* ground_truth);

  /// Closes the stream and moves the log and its image folder into place (close() then
  /// commitStaged(stagedMoves()), all or nothing).
  Status finish();

  /// Writes the end marker and closes the stream; the output stays staged (partial names), so
  /// that a caller can swap it in together with its own files.
  Status close();
  /// The (staged, final) paths close() leaves for commitStaged: image folder, then log.
  std::vector<StagedMove> stagedMoves() const;
  /// After the caller committed stagedMoves(): the writer no longer removes them.
  void release() { finished_ = true; }

  int framesWritten() const { return frames_; }
  /// Folder the external images end up in ("<stem>_Images").
  const std::string& imagesDir() const { return images_dir_; }

 private:
  struct Impl;
  RawlogWriter() = default;
  std::unique_ptr<Impl> impl_;
  std::string path_, partial_path_, images_dir_, partial_images_dir_;
  StereoRig rig_;
  RawlogWriterOptions options_;
  int frames_ = 0;
  int64_t last_t_ns_ = 0;
  bool finished_ = false;
  bool closed_ = false;
};

/// Folder of a rawlog's external images: "<dir>/<stem>_Images" (or _images, _IMAGES) when it
/// exists, else "<dir>/Images" (MRPT's convention).
std::string imagesDirectoryFor(const std::string& rawlog_path);

/// Largest coordinate a log's ground-truth translation may have [m]; a frame with a larger, NaN
/// or infinite ground-truth pose (or a non-finite ground-truth depth) is an error naming it.
/// Odometry is delivered as read (`twocam run` skips frames with non-finite odometry).
inline constexpr double kMaxLogCoordinateM = 1e6;

/// One frame read from a log.
struct LogFrame {
  int index = 0;
  StereoFrame stereo;
  std::optional<OdometrySample> odometry;
  /// The frame's odometry is synthetic (label kSyntheticOdometryLabel), not measured.
  bool odometry_synthetic = false;
  std::optional<GroundTruthFrame> ground_truth;
};

/// Reads stereo frames (with odometry and ground truth when present) from an MRPT rawlog:
/// TwoCam's own logs and any observations-only or sensory-frame rawlog with
/// CObservationStereoImages (docs/recorded_data.md). Odometry belongs to a frame when it has the
/// frame's time stamp: a CObservationOdometry (any label), or in sensory-frame logs the
/// CActionRobotMovement2D increments composed up to the frame (an odometry observation with the
/// frame's stamp wins). Frames come from the first stereo label met; the images must be
/// rectified (zero distortion, MRPT's convention), of the observation's calibrated size, and the
/// calibration must not change within the log. Errors name the log file and the frame.
/// Time stamps: TwoCam's writer stores t_ns as MRPT clock ticks unchanged; real-clock MRPT
/// stamps (dates after 1893) come back as UNIX-epoch nanoseconds.
class RawlogReader {
 public:
  /// Opens the log; reads up to the first stereo observation to learn the rig.
  static Status open(const std::string& path, std::unique_ptr<RawlogReader>* out);
  ~RawlogReader();
  RawlogReader(const RawlogReader&) = delete;
  RawlogReader& operator=(const RawlogReader&) = delete;

  /// Reads the next frame. Returns false at the end of the log; *status says whether the end
  /// was clean or an error (truncated or corrupt log, unreadable image).
  bool next(LogFrame* frame, Status* status);

  /// Rig of the log (from its first stereo observation).
  const StereoRig& rig() const { return rig_; }

  /// A TwoCam log whose header marks its odometry synthetic: the note saying how it was made
  /// (RawlogWriterOptions::synthetic_odometry). nullopt for measured or simulated odometry and
  /// for logs of other tools and of TwoCam versions before the mark.
  [[nodiscard]] const std::optional<std::string>& syntheticOdometry() const;

 private:
  struct Impl;
  RawlogReader() = default;
  std::unique_ptr<Impl> impl_;
  StereoRig rig_;
  int index_ = 0;
};

}  // namespace twocam::io
