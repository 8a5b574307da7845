#pragma once
/// The run's side of the landmark store (store/landmark_store.h, Paper A §5.5.2: the robot's
/// main computer keeps the landmark database): `twocam run LOG --map MAP.db` records every
/// confirmed landmark (position and covariance in the map frame, confidence, observation count,
/// first and last seen, a descriptor from the confirming frame) and every frame's body pose as
/// a keyframe, one transaction per
/// `frames_per_commit` frames, so a killed run leaves the map as of its last commit.
///
/// The map frame is the run's world frame (the estimated one with localisation, the odometry
/// frame without). A map that already holds landmarks is refused: merging a run into it is not
/// built yet (issue 25); pipeline/map_relocalizer.h localises a run in it.

#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "common/rig.h"
#include "common/status.h"
#include "frontend/descriptors.h"
#include "pipeline/run.h"
#include "store/landmark_store.h"

namespace twocam::pipeline {

struct MapRecorderOptions {
  /// Frames per store transaction [-]: 10 costs about 1 ms per frame on this machine's disk
  /// with synchronous commits, one per frame 1.6-4.6 ms (docs/store.md).
  int frames_per_commit = 10;
  store::LandmarkStoreOptions store;
  /// The appearance kept with each landmark for relocalisation, taken in the left image of the
  /// frame that confirmed it at its projection there (frontend/descriptors.h). ORB by default:
  /// docs/relocalization.md.
  frontend::DescriptorOptions descriptors;
  [[nodiscard]] Status validate() const;
};

/// The rig as YAML text (the world file's `rig:` keys), for the store's session record.
std::string rigText(const StereoRig& rig);

/// Position covariance [m^2] in the world frame of a stereo point measured at (u, v, d) by the
/// left camera at T_w_cl, with pixel and disparity noise sigma_px, sigma_d_px (first-order
/// propagation through the rectified triangulation). False for d <= 0.
bool stereoPointCovariance(const StereoRig& rig,
                           const Eigen::Isometry3d& T_w_cl,
                           double u_px,
                           double v_px,
                           double d_px,
                           double sigma_px,
                           double sigma_d_px,
                           Eigen::Matrix3d* cov_w);

class MapRecorder {
 public:
  /// Opens or creates the map at `path` and starts a session. Errors (nothing written): the
  /// store refuses the file (store::LandmarkStore::open), or it already holds landmarks.
  static Status open(const std::string& path,
                     const std::string& rig_text,
                     const std::string& config_text,
                     const std::string& log_path,
                     const MapRecorderOptions& options,
                     std::unique_ptr<MapRecorder>* out);

  /// After each processed frame (RunCallbacks::on_frame): its pose as a keyframe; the landmarks
  /// confirmed or seen in it, and the confirmed landmarks removed, are queued and written every
  /// frames_per_commit frames.
  Status addFrame(const RunFrame& frame);
  /// Writes what is queued. Call once at the end of the run.
  Status finish();

  [[nodiscard]] int32_t session() const { return session_; }
  [[nodiscard]] int64_t landmarksWritten() const { return static_cast<int64_t>(in_store_.size()); }

 private:
  MapRecorder() = default;
  Status flush();

  MapRecorderOptions options_;
  std::unique_ptr<store::LandmarkStore> store_;
  int32_t session_ = 0;
  store::StoreBatch batch_;
  int frames_in_batch_ = 0;
  std::unordered_set<uint64_t> in_store_;
  /// Every recorded landmark's descriptor (an upsert replaces the whole row).
  std::unordered_map<uint64_t, frontend::Descriptor> descriptors_;
};

}  // namespace twocam::pipeline
