#pragma once
/// Localising a run in a saved map (`twocam run LOG --map MAP.db --localize-only`, issue 25
/// part 4): each frame, until one is placed, the frame's stereo points (the best, left-right
/// consistent hypothesis of each corner) with their descriptors are matched to the map's
/// landmarks and the pose solved and verified (localization/relocalize.h). The run's first
/// placed frame gives T_m_o, the run's world frame in the map's; from then on every pose of the
/// run is also given in the map frame (T_m_b = T_m_o T_o_b). The map is read only.
///
/// After placement the map's landmarks join the run's tracker (takeLandmarksToRestore), so that
/// the run localises on them and the map corrects its drift. Recording the run into the map once
/// placed is pipeline/map_session.h's (MapRecorder::extend).

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/rig.h"
#include "common/status.h"
#include "common/timer.h"
#include "frontend/descriptors.h"
#include "io/trajectory.h"
#include "localization/relocalize.h"
#include "pipeline/run.h"

namespace twocam::pipeline {

struct MapRelocalizerOptions {
  localization::RelocalizationOptions relocalization;
  /// The descriptor the map's landmarks were recorded with (MapRecorderOptions::descriptors).
  frontend::DescriptorOptions descriptors;
  /// Every frame is tried for the first `every_frame_attempts` frames, then one frame in
  /// `later_attempt_stride`: an attempt costs 0.3-0.4 s against a 30 000-landmark map, and a log
  /// that is not in the map would otherwise pay it on every frame [frames]. The measured
  /// placements all came within 2 frames (docs/experiments/2026-12-03-relocalization-in-run.md).
  int every_frame_attempts = 10;
  int later_attempt_stride = 10;
  /// Hand the tracker every landmark of the map after placement, also those recorded without a
  /// descriptor of the kind (near the image border when confirmed: 9 % of an office map).
  /// Extending a map needs them all, or the run maps those points again; false (--localize-only)
  /// restores only the landmarks relocalisation matches against.
  bool restore_without_descriptor = false;
  [[nodiscard]] Status validate() const;
};

/// What relocalisation did over the run.
struct RelocalizationReport {
  /// First frame placed in the map (log index), -1 when none.
  int32_t frame = -1;
  /// Frames tried up to and including that one (MapRelocalizerOptions: every frame at first,
  /// then one in later_attempt_stride).
  int attempts = 0;
  /// The placed frame's pose in the map and the relocalisation's evidence.
  Eigen::Isometry3d T_m_b = Eigen::Isometry3d::Identity();
  int inliers = 0;
  int verified = 0;
  double verified_fraction = 0.0;
  /// Why the last failed attempt failed (localization::RelocalizationResult::reason).
  std::string last_reason;
  /// The map's landmarks with a descriptor of the configured kind.
  int64_t map_landmarks = 0;
  /// Per attempt: relocalize() time [ms].
  std::vector<double> attempt_ms;
  /// Wall time of open(): the store opened and read, the landmarks to match kept [ms].
  double open_ms = 0.0;
  /// Wall time from the start of open() to the end of the placing attempt (the frames processed
  /// meanwhile included) [ms]; 0 when never placed.
  double placed_ms = 0.0;
  /// The run's poses in the map frame from the placed frame on.
  std::vector<io::TimedPose> map_track;
  /// Map landmarks handed to the run's tracker after placement.
  int64_t restored = 0;
};

class MapRelocalizer {
 public:
  /// Reads the map at `path` (read only: the file is never written). Errors: the store refuses
  /// it, or none of its landmarks has a descriptor of options.descriptors.kind.
  static Status open(const std::string& path,
                     const StereoRig& rig,
                     const MapRelocalizerOptions& options,
                     std::unique_ptr<MapRelocalizer>* out);

  /// After each processed frame (RunCallbacks::on_frame).
  Status addFrame(const RunFrame& frame);
  [[nodiscard]] const RelocalizationReport& report() const { return report_; }
  /// Once, after the frame that was placed (RunCallbacks::between_frames): the map's landmarks
  /// in the run's world frame (p_o = T_m_o^-1 p_m), handed to the tracker so that the run
  /// localises on the map from there (Pipeline::restoreLandmarks). Empty otherwise. With
  /// `map_ids`, their stored ids, in parallel.
  std::vector<Eigen::Vector3d> takeLandmarksToRestore(std::vector<uint64_t>* map_ids = nullptr);
  /// The run's world frame in the map's, once placed (identity before).
  [[nodiscard]] const Eigen::Isometry3d& T_m_o() const { return T_m_o_; }
  [[nodiscard]] bool placed() const { return placed_; }

 private:
  MapRelocalizer() = default;

  StereoRig rig_;
  MapRelocalizerOptions options_;
  std::vector<localization::MapLandmark> map_;
  /// What takeLandmarksToRestore hands over: stored id and p_m.
  std::vector<std::pair<uint64_t, Eigen::Vector3d>> restore_;
  bool placed_ = false;
  bool restored_ = false;
  int frames_seen_ = 0;  // processed frames before placement
  Eigen::Isometry3d T_m_o_ = Eigen::Isometry3d::Identity();
  RelocalizationReport report_;
  Timer since_open_;
};

/// The descriptor kind as stored (StoredLandmark::descriptor_kind): 0 = none, 1 + the kind.
uint8_t storedDescriptorKind(frontend::DescriptorKind kind);

}  // namespace twocam::pipeline
