#pragma once
/// The landmark store: confirmed landmarks, keyframe poses and the runs (sessions) that made them,
/// in one SQLite file that outlives the process (Paper A §5.5.2: the main computer's database).
/// The file is the map. Schema, versioning and the crash-safety model: docs/store.md.
///
/// Frames: m = map frame (the frame every session's landmarks and keyframes are expressed in),
/// b = body. Units: metres, nanoseconds.
///
/// Ownership and threads: a LandmarkStore owns its SQLite connection; one thread at a time.
/// Several processes may read one file; one writes at a time (SQLite's WAL locking).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/status.h"

namespace twocam::store {

/// `PRAGMA application_id` of a TwoCam store ("TCAM").
constexpr int32_t kStoreApplicationId = 0x5443414D;
/// `PRAGMA user_version`: the schema this code writes and reads.
constexpr int32_t kStoreSchemaVersion = 1;

/// One confirmed landmark as the map keeps it.
struct StoredLandmark {
  /// Unique in the store across sessions, < 2^63 (SQLite integers are signed).
  uint64_t id = 0;
  /// Position in the map frame [m]; must be finite.
  Eigen::Vector3d p_m = Eigen::Vector3d::Zero();
  /// Position covariance in the map frame [m^2].
  Eigen::Matrix3d cov_m = Eigen::Matrix3d::Zero();
  /// The confirmation policy's confidence in [0, 1].
  double confidence = 0.0;
  int32_t observations = 0;
  /// The session that created it (LandmarkStore::beginSession()).
  int32_t session = 0;
  int32_t first_seen_frame = 0;
  int32_t last_seen_frame = 0;
  int64_t first_seen_t_ns = 0;
  int64_t last_seen_t_ns = 0;
  /// What `descriptor` holds (0 = none; the relocalisation code defines the others).
  uint8_t descriptor_kind = 0;
  std::vector<uint8_t> descriptor;
};

/// The pose of one keyframe of a session.
struct StoredKeyframe {
  int32_t session = 0;
  int32_t frame = 0;
  int64_t t_ns = 0;
  /// Body pose in the map frame: p_m = T_m_b * p_b. Stored as translation + unit quaternion.
  Eigen::Isometry3d T_m_b = Eigen::Isometry3d::Identity();
};

/// One run that wrote into the store.
struct StoredSession {
  int32_t id = 0;
  /// The rig and the effective config as text (as the run wrote them), for reproducing it.
  std::string rig_text;
  std::string config_text;
  /// UTC start, ISO 8601 ("2026-12-03T17:04:05Z").
  std::string started;
  std::string log_path;
};

/// What a store holds (`twocam map info`).
struct StoreInfo {
  int32_t schema_version = 0;
  /// meta: when the file was created (ISO 8601 UTC) and by which twocam version.
  std::string created;
  std::string tool_version;
  std::vector<StoredSession> sessions;
  int64_t landmark_count = 0;
  int64_t keyframe_count = 0;
  /// The id the next new landmark should take (one past the largest id ever written).
  uint64_t next_landmark_id = 1;
  /// Bounding box of the landmark positions in the map frame [m]; meaningful when
  /// landmark_count > 0 (zero otherwise).
  Eigen::Vector3d box_min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d box_max_m = Eigen::Vector3d::Zero();
  /// Size of the database file and of its write-ahead log beside it (PATH-wal) [bytes].
  int64_t file_bytes = 0;
  int64_t wal_bytes = 0;
};

/// The writes of one call to writeBatch(): committed together or not at all.
struct StoreBatch {
  /// Inserted, or replacing the landmark with the same id.
  std::vector<StoredLandmark> upserts;
  /// Ids to delete; unknown ids are ignored. Applied after the upserts.
  std::vector<uint64_t> removed;
  /// Inserted, or replacing the keyframe with the same (session, frame).
  std::vector<StoredKeyframe> keyframes;
};

enum class OpenMode {
  /// Open an existing store to read and write, or create a new one at a missing path.
  kCreateOrExtend,
  /// Open an existing store; nothing is ever written to it.
  kReadOnly,
};

struct LandmarkStoreOptions {
  /// Commit durability. true (default): `synchronous=FULL`: every commit is fsync'ed before
  /// writeBatch() returns, so it survives a killed process and a power loss (Paper A: the map is
  /// "retained during a power down"). false: `synchronous=NORMAL`: a commit survives a killed
  /// process (the write-ahead log is in the OS's cache), a power loss or OS crash can lose the
  /// last commits (never the file's consistency). Measured cost of FULL: docs/store.md.
  bool sync_every_commit = true;
  /// How long a writer waits for another process's lock before failing [ms].
  int busy_timeout_ms = 5000;
  [[nodiscard]] Status validate() const;
};

/// The landmark store on one SQLite file. See the file comment.
class LandmarkStore {
 public:
  /// Opens or creates the store at `path`. Before anything is written the file is checked with a
  /// read-only connection; it is refused (error naming the path, file untouched) when it is not
  /// an SQLite database, an SQLite database that is not a TwoCam store (application_id), a store
  /// of a newer or unknown schema version, or corrupt (`PRAGMA quick_check`). A missing path is an
  /// error in kReadOnly mode; kCreateOrExtend creates it (the folder must exist).
  static Status open(const std::string& path,
                     OpenMode mode,
                     std::unique_ptr<LandmarkStore>* out,
                     const LandmarkStoreOptions& options = {});

  ~LandmarkStore();
  LandmarkStore(const LandmarkStore&) = delete;
  LandmarkStore& operator=(const LandmarkStore&) = delete;

  /// Records a new session (a run) and returns its id in *session (1, 2, ...: one past the
  /// largest). An error in read-only mode.
  [[nodiscard]] Status beginSession(const std::string& rig_text,
                                    const std::string& config_text,
                                    const std::string& log_path,
                                    int32_t* session);

  /// Applies a batch in one transaction (all or nothing). Errors, with nothing written: read-only
  /// mode, a non-finite position, an id >= 2^63, a session that beginSession() did not create.
  [[nodiscard]] Status writeBatch(const StoreBatch& batch);

  /// Every landmark, sorted by id.
  [[nodiscard]] Status loadAll(std::vector<StoredLandmark>* out) const;
  /// Landmarks with min_m <= p_m <= max_m (componentwise, inclusive), sorted by id. Uses the
  /// R*Tree index.
  [[nodiscard]] Status queryBox(const Eigen::Vector3d& min_m,
                                const Eigen::Vector3d& max_m,
                                std::vector<StoredLandmark>* out) const;
  /// The ids of the R*Tree entries meeting the box, sorted: every landmark of queryBox's answer
  /// and possibly some within a float rounding (~1e-7 relative) outside it, without reading the
  /// rows (the working set asks which rows it lacks before it reads them).
  [[nodiscard]] Status queryBoxIds(const Eigen::Vector3d& min_m,
                                   const Eigen::Vector3d& max_m,
                                   std::vector<uint64_t>* ids) const;
  /// The rows of these ids, in their order. Error when one is not in the map.
  [[nodiscard]] Status loadByIds(const std::vector<uint64_t>& ids,
                                 std::vector<StoredLandmark>* out) const;
  /// Landmarks with |p_m - center_m| <= radius_m, sorted by id. Uses the R*Tree index.
  [[nodiscard]] Status queryRadius(const Eigen::Vector3d& center_m,
                                   double radius_m,
                                   std::vector<StoredLandmark>* out) const;
  /// The keyframes of one session, sorted by frame.
  [[nodiscard]] Status keyframes(int32_t session, std::vector<StoredKeyframe>* out) const;
  [[nodiscard]] Status info(StoreInfo* out) const;
  /// `PRAGMA integrity_check` of the whole file: ok, or an error with SQLite's first findings.
  [[nodiscard]] Status integrityCheck() const;

  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] OpenMode mode() const { return mode_; }

 private:
  struct Impl;
  LandmarkStore(std::string path, OpenMode mode);

  std::string path_;
  OpenMode mode_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace twocam::store
