#pragma once
/// The run's side of the landmark store (store/landmark_store.h, Paper A §5.5.2: the robot's
/// main computer keeps the landmark database): `twocam run LOG --map MAP.db` records every
/// confirmed landmark (position and covariance in the map frame, confidence, observation count,
/// first and last seen, a descriptor from the confirming frame) and every frame's body pose as
/// a keyframe, one transaction per
/// `frames_per_commit` frames, so a killed run leaves the map as of its last commit.
///
/// A new map (open): its frame is the run's world frame (the estimated one with localisation,
/// the odometry frame without), and its landmark ids are the tracker's. A map that already holds
/// landmarks is extended (extend) once the run has been placed in it (pipeline/map_relocalizer.h,
/// pipeline/map_session.h): the run is a new session, its poses and new landmarks are written in
/// the map frame (T_m_o, the relocalisation's), new landmarks take ids from the store's
/// next_landmark_id on, and the map's landmarks the run re-sees (restored into its tracker,
/// adoptRestored) are updated under their stored ids.

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "common/rig.h"
#include "common/status.h"
#include "frontend/descriptors.h"
#include "landmarks/landmark_database.h"
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
  /// Extending a map: a landmark the run confirms close to an earlier session's landmark whose
  /// descriptor is within `merge_max_descriptor_distance` of its own (the nearest such by
  /// descriptor) is that landmark seen again, not a new one: the earlier row is updated. Close:
  /// within `merge_radius_m` and within the `merge_gate_chi2` gate of their position covariances
  /// plus `merge_map_sigma_m` on each axis. The map is only as consistent as the run that built
  /// it (1-4 cm off in places on office), so a restored landmark the tracker's gates
  /// missed is caught here. The largest distance of a merge [m]; 0 switches the merge off.
  double merge_radius_m = 0.3;
  /// The map's inconsistency with the run, added to both covariances (sigma per axis) [m].
  double merge_map_sigma_m = 0.02;
  /// Gate on the squared Mahalanobis distance of the two positions: 11.34 is chi-squared's 99 %
  /// for 3 degrees of freedom [-].
  double merge_gate_chi2 = 11.34;
  /// Descriptor distance of a merge (frontend::descriptorDistance: ORB bits / 256) [-].
  double merge_max_descriptor_distance = 0.2;
  [[nodiscard]] Status validate() const;
};

/// One store transaction the recorder committed (MapRecorder::setCommitObserver): the
/// session, and the last log frame whose pose and landmarks it holds. Every frame of the session
/// recorded up to `last_frame` is in the store when the observer is called.
struct MapCommit {
  int32_t session = 0;
  int32_t last_frame = -1;
  /// Keyframes the session has committed so far [-].
  int64_t keyframes = 0;
};

using MapCommitObserver = std::function<void(const MapCommit&)>;

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
  /// store refuses the file (store::LandmarkStore::open), or it already holds landmarks (extend
  /// continues such a map).
  static Status open(const std::string& path,
                     const std::string& rig_text,
                     const std::string& config_text,
                     const std::string& log_path,
                     const MapRecorderOptions& options,
                     std::unique_ptr<MapRecorder>* out);

  /// Continues the map at `path` (which holds landmarks) with a new session of a run placed in it
  /// at log frame `placed_frame`, `T_m_o` being the run's world frame in the map's. Landmarks the
  /// run confirmed up to that frame are never recorded (they were confirmed before the map's
  /// landmarks joined the tracker, and may be points the map has); frames are recorded from the
  /// placed one on. Errors (nothing written): the store refuses the file.
  static Status extend(const std::string& path,
                       const std::string& rig_text,
                       const std::string& config_text,
                       const std::string& log_path,
                       const Eigen::Isometry3d& T_m_o,
                       int32_t placed_frame,
                       const MapRecorderOptions& options,
                       std::unique_ptr<MapRecorder>* out);

  /// Extending: the map's landmarks `map_ids` joined the run's tracker as `tracker_ids` (in
  /// parallel; Pipeline::restoreLandmarks). When the run sees one again its stored row is updated
  /// (observations added to the stored count, confidence, last seen), its position, descriptor
  /// and session kept; a later session never removes an earlier session's landmark. Error when
  /// the sizes differ or an id is not in the map.
  Status adoptRestored(const std::vector<uint64_t>& tracker_ids,
                       const std::vector<uint64_t>& map_ids);

  /// The bounded working set (pipeline/working_set.h) pages confirmed landmarks out of the
  /// tracker and back in from the store; the recorder keeps the ids and the rows' bases:
  ///
  /// True when nothing is queued: every landmark row and pose recorded so far is committed.
  [[nodiscard]] bool committed() const {
    return batch_.upserts.empty() && batch_.removed.empty() && batch_.keyframes.empty();
  }
  /// The store id of a live tracker landmark whose row is in the map, or 0 (a candidate, or a
  /// landmark the run confirmed before it was placed in the map).
  [[nodiscard]] uint64_t storeIdOf(uint64_t tracker_id) const;
  /// True when a live confirmed landmark of `db` (the run's tracker) is this map row: the
  /// session's own under its id, or a restored, paged-in or merged one (storeIdOf's inverse).
  [[nodiscard]] bool trackerHolds(uint64_t store_id, const landmarks::LandmarkDatabase& db) const;
  /// Before the tracker releases these landmarks (Pipeline::pageOutLandmarks; `db` still holds
  /// them): their rows stay in the map as last written, and the recorder forgets its state for
  /// them (a restored landmark's observations are folded into its row's base). Call only when
  /// committed(). Error when an id is not a landmark of the map.
  Status pageOut(const landmarks::LandmarkDatabase& db, const std::vector<uint64_t>& tracker_ids);
  /// These map rows joined the tracker as `tracker_ids` (in parallel): when the run sees one
  /// again its row is updated as a restored landmark's (observations added to the stored count,
  /// position, descriptor and session kept). Error when the sizes differ.
  Status adoptPagedIn(const std::vector<uint64_t>& tracker_ids,
                      std::vector<store::StoredLandmark> rows);
  [[nodiscard]] const store::LandmarkStore& store() const { return *store_; }
  /// The run's world frame in the map's (identity for a new map).
  [[nodiscard]] const Eigen::Isometry3d& T_m_o() const { return T_m_o_; }

  /// After each processed frame (RunCallbacks::on_frame): its pose as a keyframe; the landmarks
  /// confirmed or seen in it, and the confirmed landmarks removed, are queued and written every
  /// frames_per_commit frames.
  Status addFrame(const RunFrame& frame);
  /// Writes what is queued. Call once at the end of the run.
  Status finish();
  /// Called after each transaction that committed at least one keyframe, once writeBatch has
  /// returned (so a process killed after the call keeps what it reports; one killed between the
  /// commit and the call holds a frame more than was reported). Empty: nothing is called.
  void setCommitObserver(MapCommitObserver observer) { on_commit_ = std::move(observer); }

  [[nodiscard]] int32_t session() const { return session_; }
  /// The session's own landmarks in the map (inserted, less those it removed again).
  [[nodiscard]] int64_t landmarksWritten() const { return own_written_; }
  /// Extending: earlier sessions' landmarks this session saw again (updated rows).
  [[nodiscard]] int64_t landmarksUpdated() const { return static_cast<int64_t>(updated_.size()); }
  /// Extending: landmarks the run confirmed that were merged into an earlier session's
  /// (MapRecorderOptions::merge_radius_m).
  [[nodiscard]] int64_t landmarksMerged() const { return merged_; }
  /// Poses written (one per recorded frame).
  [[nodiscard]] int64_t keyframesWritten() const { return keyframes_written_; }
  [[nodiscard]] bool extending() const { return extending_; }
  /// Extending: the first id this session gave a new landmark (the store's next id when it began).
  [[nodiscard]] uint64_t firstNewId() const { return first_new_id_; }

 private:
  MapRecorder() = default;
  Status flush();
  static Status openStore(const std::string& path,
                          const MapRecorderOptions& options,
                          std::unique_ptr<store::LandmarkStore>* st,
                          store::StoreInfo* info);

  MapRecorderOptions options_;
  std::unique_ptr<store::LandmarkStore> store_;
  int32_t session_ = 0;
  store::StoreBatch batch_;
  int frames_in_batch_ = 0;
  /// Tracker ids of the session's own landmarks in the store that are live in the tracker (a
  /// landmark paged out leaves the set, its row stays), and how many the session wrote.
  std::unordered_set<uint64_t> in_store_;
  int64_t own_written_ = 0;
  /// Rows of landmarks paged back in (adoptPagedIn), by store id, while they are live: the base
  /// of their updates (before earlier_).
  std::unordered_map<uint64_t, store::StoredLandmark> paged_base_;
  /// The row an update of store id `sid` starts from.
  [[nodiscard]] const store::StoredLandmark& baseRow(uint64_t sid) const;
  /// The row of a restored landmark `l` (store id `sid`) with the run's observations added.
  store::StoredLandmark updatedRow(const landmarks::LandmarkDatabase& db,
                                   const landmarks::Landmark& l,
                                   uint64_t sid,
                                   int64_t t_ns);
  /// Every recorded landmark's descriptor by tracker id (an upsert replaces the whole row).
  std::unordered_map<uint64_t, frontend::Descriptor> descriptors_;
  int64_t keyframes_written_ = 0;
  int64_t keyframes_committed_ = 0;
  MapCommitObserver on_commit_;

  // Extending (extend()): the map frame, the placed frame, and the ids.
  bool extending_ = false;
  Eigen::Isometry3d T_m_o_ = Eigen::Isometry3d::Identity();
  int32_t placed_frame_ = -1;
  uint64_t first_new_id_ = 0;
  uint64_t next_id_ = 0;
  /// Tracker id -> store id: the session's new landmarks and the restored map landmarks.
  std::unordered_map<uint64_t, uint64_t> store_id_;
  /// Extending: store id -> tracker id of the session's own new landmarks while the tracker
  /// holds them (a new map's own landmarks keep their tracker id as store id).
  std::unordered_map<uint64_t, uint64_t> own_tracker_of_;
  /// Tracker ids of restored map landmarks.
  std::unordered_set<uint64_t> restored_;
  /// The map's rows as the session found them, by store id (the base of an update).
  std::unordered_map<uint64_t, store::StoredLandmark> earlier_;
  /// Store ids of earlier landmarks the session updated.
  std::unordered_set<uint64_t> updated_;
  /// Store id -> the tracker ids that saw it (restored, and merged confirmations).
  std::unordered_map<uint64_t, std::vector<uint64_t>> seen_as_;
  /// Earlier landmarks by merge_radius_m cell of p_m.
  std::unordered_map<uint64_t, std::vector<uint64_t>> earlier_cells_;
  int64_t merged_ = 0;
  /// The earlier landmark a new confirmation at p_m (covariance cov_m) with this descriptor is,
  /// or 0.
  uint64_t mergeTarget(const Eigen::Vector3d& p_m,
                       const Eigen::Matrix3d& cov_m,
                       const frontend::Descriptor& d) const;
  [[nodiscard]] uint64_t cellKey(const Eigen::Vector3d& p_m, int dx, int dy, int dz) const;
};

}  // namespace twocam::pipeline
