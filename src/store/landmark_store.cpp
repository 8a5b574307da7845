#include "store/landmark_store.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "store/sqlite_handle.h"

namespace twocam::store {

namespace fs = std::filesystem;

namespace {

/// The first 16 bytes of every SQLite 3 database file.
constexpr char kSqliteMagic[16] = "SQLite format 3";
/// Ids are SQLite integers (signed 64 bit).
constexpr uint64_t kMaxId = static_cast<uint64_t>(INT64_MAX);

constexpr const char* kSchemaSql = R"SQL(
CREATE TABLE meta(key TEXT PRIMARY KEY, value TEXT NOT NULL) WITHOUT ROWID;
CREATE TABLE sessions(
  id INTEGER PRIMARY KEY, rig TEXT NOT NULL, config TEXT NOT NULL, started TEXT NOT NULL,
  log_path TEXT NOT NULL);
CREATE TABLE landmarks(
  id INTEGER PRIMARY KEY, x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL,
  cov BLOB NOT NULL, confidence REAL NOT NULL, observations INTEGER NOT NULL,
  session INTEGER NOT NULL REFERENCES sessions(id),
  first_seen_frame INTEGER NOT NULL, last_seen_frame INTEGER NOT NULL,
  first_seen_t_ns INTEGER NOT NULL, last_seen_t_ns INTEGER NOT NULL,
  descriptor_kind INTEGER NOT NULL, descriptor BLOB NOT NULL);
CREATE VIRTUAL TABLE landmark_rtree USING rtree(id, min_x, max_x, min_y, max_y, min_z, max_z);
CREATE TABLE keyframes(
  session INTEGER NOT NULL REFERENCES sessions(id), frame INTEGER NOT NULL,
  t_ns INTEGER NOT NULL, tx REAL NOT NULL, ty REAL NOT NULL, tz REAL NOT NULL,
  qw REAL NOT NULL, qx REAL NOT NULL, qy REAL NOT NULL, qz REAL NOT NULL,
  PRIMARY KEY(session, frame)) WITHOUT ROWID;
)SQL";

/// Page cache of one connection: 64 MiB (negative = KiB), so a 100,000-landmark map (about
/// 30 MB with its index) stays in memory after the first reads instead of one pread per page.
constexpr const char* kCacheSql = "PRAGMA cache_size=-65536";

constexpr const char* kLandmarkColumns =
    "l.id, l.x, l.y, l.z, l.cov, l.confidence, l.observations, l.session, l.first_seen_frame, "
    "l.last_seen_frame, l.first_seen_t_ns, l.last_seen_t_ns, l.descriptor_kind, l.descriptor";

/// The R*Tree entries meeting the box ?1..?6 = min x, max x, min y, max y, min z, max z (table
/// alias r).
constexpr const char* kRtreeMeetsBox =
    "r.max_x >= ?1 AND r.min_x <= ?2 AND r.max_y >= ?3 AND r.min_y <= ?4 AND r.max_z >= ?5 AND "
    "r.min_z <= ?6";

Status checkBox(const std::string& path,
                const Eigen::Vector3d& min_m,
                const Eigen::Vector3d& max_m) {
  if (min_m.allFinite() && max_m.allFinite()) return Status::ok();
  return Status::error("map '" + path + "': query box with a non-finite corner");
}

std::string utcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

std::string hex32(int64_t value) {
  char text[16];
  std::snprintf(text, sizeof(text), "0x%08X", static_cast<unsigned>(value & 0xFFFFFFFF));
  return text;
}

StoredLandmark readLandmark(const SqliteStatement& s) {
  StoredLandmark l;
  l.id = static_cast<uint64_t>(s.columnInt(0));
  l.p_m = {s.columnDouble(1), s.columnDouble(2), s.columnDouble(3)};
  const std::vector<uint8_t> cov = s.columnBlob(4);
  // Written as 9 doubles of the host (little-endian on every platform we build for).
  TWOCAM_CHECK(cov.size() == sizeof(double) * 9)
      << "landmark " << l.id << ": cov blob of " << cov.size() << " bytes";
  std::memcpy(l.cov_m.data(), cov.data(), cov.size());
  l.confidence = s.columnDouble(5);
  l.observations = static_cast<int32_t>(s.columnInt(6));
  l.session = static_cast<int32_t>(s.columnInt(7));
  l.first_seen_frame = static_cast<int32_t>(s.columnInt(8));
  l.last_seen_frame = static_cast<int32_t>(s.columnInt(9));
  l.first_seen_t_ns = s.columnInt(10);
  l.last_seen_t_ns = s.columnInt(11);
  l.descriptor_kind = static_cast<uint8_t>(s.columnInt(12));
  l.descriptor = s.columnBlob(13);
  return l;
}

/// Checks an existing file with a read-only connection; nothing is written to it.
Status checkExisting(const std::string& path, SqliteConnection* connection, int busy_timeout_ms) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return Status::error("map '" + path + "' is not a regular file");
  }
  const auto bytes = fs::file_size(path, ec);
  if (ec || bytes == 0) {
    return Status::error("map '" + path + "' is empty: not a TwoCam landmark store");
  }
  char header[sizeof(kSqliteMagic)] = {};
  {
    std::ifstream in(path, std::ios::binary);
    in.read(header, sizeof(header));
    if (!in || std::memcmp(header, kSqliteMagic, sizeof(header)) != 0) {
      return Status::error("map '" + path +
                           "' is not an SQLite database (no 'SQLite format 3' header): not a "
                           "TwoCam landmark store");
    }
  }
  if (Status st = connection->open(path, SQLITE_OPEN_READONLY); !st) return st;
  sqlite3_busy_timeout(connection->db(), busy_timeout_ms);
  int64_t application_id = 0;
  if (Status st = connection->queryInt("PRAGMA application_id", &application_id); !st) {
    return Status::error("map '" + path + "' is corrupt or not a database: " + st.message());
  }
  if (application_id != kStoreApplicationId) {
    return Status::error("map '" + path +
                         "' is an SQLite database but not a TwoCam landmark store "
                         "(application_id " +
                         hex32(application_id) + ", a store has " + hex32(kStoreApplicationId) +
                         ")");
  }
  int64_t version = 0;
  if (Status st = connection->queryInt("PRAGMA user_version", &version); !st) {
    return Status::error("map '" + path + "' is corrupt: " + st.message());
  }
  if (version > kStoreSchemaVersion) {
    return Status::error("map '" + path + "' has schema version " + std::to_string(version) +
                         ", newer than this twocam reads (" + std::to_string(kStoreSchemaVersion) +
                         "); open it with a newer twocam");
  }
  if (version != kStoreSchemaVersion) {
    return Status::error("map '" + path + "' has unknown schema version " +
                         std::to_string(version) + " (this twocam reads " +
                         std::to_string(kStoreSchemaVersion) + ")");
  }
  std::vector<std::string> rows;
  if (Status st = connection->queryTextColumn("PRAGMA quick_check", &rows); !st) {
    return Status::error("map '" + path + "' is corrupt: " + st.message());
  }
  if (rows.size() != 1 || rows[0] != "ok") {
    return Status::error("map '" + path + "' is corrupt (PRAGMA quick_check: " +
                         (rows.empty() ? std::string("no result") : rows[0]) + ")");
  }
  return Status::ok();
}

/// Writes a new, empty store at `path` through a temporary file renamed into place.
Status createStore(const std::string& path) {
  const std::string tmp = path + ".creating-" + std::to_string(::getpid());
  std::error_code ec;
  fs::remove(tmp, ec);
  {
    SqliteConnection db;
    if (Status st = db.open(tmp, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE); !st) return st;
    std::ostringstream sql;
    sql << "PRAGMA journal_mode=WAL; BEGIN IMMEDIATE;" << kSchemaSql
        << "PRAGMA application_id=" << kStoreApplicationId
        << "; PRAGMA user_version=" << kStoreSchemaVersion << ";"
        << "INSERT INTO meta VALUES('schema_version', '" << kStoreSchemaVersion << "');"
        << "INSERT INTO meta VALUES('created', '" << utcNow() << "');"
        << "INSERT INTO meta VALUES('tool_version', 'twocam " << TWOCAM_VERSION << "');"
        << "INSERT INTO meta VALUES('next_landmark_id', '1');"
        << "COMMIT;";
    if (Status st = db.exec(sql.str()); !st) {
      db.close();
      fs::remove(tmp, ec);
      return Status::error("cannot create map '" + path + "': " + st.message());
    }
  }  // closing checkpoints the log into the file and removes tmp-wal
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return Status::error("cannot create map '" + path + "': rename failed");
  }
  return Status::ok();
}

}  // namespace

Status LandmarkStoreOptions::validate() const {
  if (busy_timeout_ms < 0) {
    return Status::error("busy_timeout_ms = " + std::to_string(busy_timeout_ms) + "; must be >= 0");
  }
  return Status::ok();
}

struct LandmarkStore::Impl {
  // The connection is declared first so that it is destroyed after the statements.
  SqliteConnection db;
  SqliteStatement select_position, upsert_landmark, upsert_rtree, delete_landmark, delete_rtree,
      upsert_keyframe, set_meta;
  std::set<int32_t> sessions;
  uint64_t next_landmark_id = 1;

  Status prepareWriters() {
    for (auto [stmt, sql] : {
             std::pair{&select_position, "SELECT x, y, z FROM landmarks WHERE id = ?1"},
             std::pair{&upsert_landmark,
                       "INSERT OR REPLACE INTO landmarks VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, "
                       "?9, ?10, ?11, ?12, ?13, ?14)"},
             std::pair{&upsert_rtree,
                       "INSERT OR REPLACE INTO landmark_rtree VALUES(?1, ?2, ?2, ?3, ?3, ?4, ?4)"},
             std::pair{&delete_landmark, "DELETE FROM landmarks WHERE id = ?1"},
             std::pair{&delete_rtree, "DELETE FROM landmark_rtree WHERE id = ?1"},
             std::pair{&upsert_keyframe,
                       "INSERT OR REPLACE INTO keyframes VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, "
                       "?9, ?10)"},
             std::pair{&set_meta, "INSERT OR REPLACE INTO meta VALUES(?1, ?2)"},
         }) {
      if (Status st = stmt->prepare(db, sql); !st) return st;
    }
    return Status::ok();
  }

  Status loadState() {
    SqliteStatement s;
    if (Status st = s.prepare(db, "SELECT id FROM sessions"); !st) return st;
    SqliteStatement::StepResult r;
    while ((r = s.step()) == SqliteStatement::StepResult::kRow) {
      sessions.insert(static_cast<int32_t>(s.columnInt(0)));
    }
    if (r == SqliteStatement::StepResult::kError) return s.error("failed");
    SqliteStatement m;
    if (Status st = m.prepare(db, "SELECT value FROM meta WHERE key = 'next_landmark_id'"); !st) {
      return st;
    }
    if (m.step() == SqliteStatement::StepResult::kRow) {
      next_landmark_id = std::stoull(m.columnText(0));
    }
    return Status::ok();
  }

  Status setMeta(const std::string& key, const std::string& value) {
    set_meta.bindText(1, key);
    set_meta.bindText(2, value);
    return set_meta.run();
  }

  Status selectLandmarks(const std::string& sql,
                         const std::vector<double>& params,
                         std::vector<StoredLandmark>* out) {
    SqliteStatement s;
    if (Status st = s.prepare(db, sql); !st) return st;
    for (size_t i = 0; i < params.size(); ++i) s.bindDouble(static_cast<int>(i) + 1, params[i]);
    SqliteStatement::StepResult r;
    while ((r = s.step()) == SqliteStatement::StepResult::kRow) out->push_back(readLandmark(s));
    if (r == SqliteStatement::StepResult::kError) return s.error("failed");
    return Status::ok();
  }
};

LandmarkStore::LandmarkStore(std::string path, OpenMode mode)
    : path_(std::move(path)), mode_(mode), impl_(std::make_unique<Impl>()) {}

LandmarkStore::~LandmarkStore() = default;

Status LandmarkStore::open(const std::string& path,
                           OpenMode mode,
                           std::unique_ptr<LandmarkStore>* out,
                           const LandmarkStoreOptions& options) {
  out->reset();
  if (Status st = options.validate(); !st) return st;
  std::unique_ptr<LandmarkStore> store(new LandmarkStore(path, mode));
  Impl& impl = *store->impl_;
  std::error_code ec;
  const bool exists = fs::exists(path, ec);
  if (!exists && mode == OpenMode::kReadOnly) {
    return Status::error("map '" + path + "' does not exist");
  }
  const std::string synchronous =
      options.sync_every_commit ? "PRAGMA synchronous=FULL" : "PRAGMA synchronous=NORMAL";
  if (exists) {
    SqliteConnection check;
    if (Status st = checkExisting(path, &check, options.busy_timeout_ms); !st) return st;
    if (mode == OpenMode::kReadOnly) {
      check.close();
      if (Status st = impl.db.open(path, SQLITE_OPEN_READONLY); !st) return st;
      sqlite3_busy_timeout(impl.db.db(), options.busy_timeout_ms);
      if (Status st = impl.db.exec(std::string("PRAGMA query_only=ON;") + kCacheSql); !st) {
        return st;
      }
      if (Status st = impl.loadState(); !st) return st;
      *out = std::move(store);
      return Status::ok();
    }
    check.close();
    if (Status st = impl.db.open(path, SQLITE_OPEN_READWRITE); !st) return st;
    sqlite3_busy_timeout(impl.db.db(), options.busy_timeout_ms);
    for (const std::string& sql : {std::string("PRAGMA journal_mode=WAL"),
                                   synchronous,
                                   std::string("PRAGMA foreign_keys=ON"),
                                   std::string(kCacheSql)}) {
      if (Status st = impl.db.exec(sql); !st) return st;
    }
  } else {
    const fs::path parent = fs::path(path).parent_path();
    if (!parent.empty() && !fs::is_directory(parent, ec)) {
      return Status::error("map '" + path + "': folder '" + parent.string() + "' does not exist");
    }
    // A log without its database would be replayed into the new file: refuse.
    if (fs::exists(path + "-wal", ec)) {
      return Status::error("map '" + path + "' does not exist but its write-ahead log '" + path +
                           "-wal' does: restore the map or remove the log");
    }
    // Built under a temporary name and renamed into place: a process killed while creating
    // leaves no half-made store at `path`.
    if (Status st = createStore(path); !st) return st;
    if (Status st = impl.db.open(path, SQLITE_OPEN_READWRITE); !st) return st;
    sqlite3_busy_timeout(impl.db.db(), options.busy_timeout_ms);
    for (const std::string& sql :
         {synchronous, std::string("PRAGMA foreign_keys=ON"), std::string(kCacheSql)}) {
      if (Status st = impl.db.exec(sql); !st) return st;
    }
  }
  if (!impl.upsert_landmark.prepared()) {
    if (Status st = impl.prepareWriters(); !st) return st;
  }
  if (Status st = impl.loadState(); !st) return st;
  *out = std::move(store);
  return Status::ok();
}

Status LandmarkStore::beginSession(const std::string& rig_text,
                                   const std::string& config_text,
                                   const std::string& log_path,
                                   int32_t* session) {
  if (mode_ == OpenMode::kReadOnly) {
    return Status::error("map '" + path_ + "' is open read-only: cannot begin a session");
  }
  const int32_t id = impl_->sessions.empty() ? 1 : *impl_->sessions.rbegin() + 1;
  SqliteStatement s;
  if (Status st = s.prepare(impl_->db, "INSERT INTO sessions VALUES(?1, ?2, ?3, ?4, ?5)"); !st) {
    return st;
  }
  s.bindInt(1, id);
  s.bindText(2, rig_text);
  s.bindText(3, config_text);
  s.bindText(4, utcNow());
  s.bindText(5, log_path);
  if (Status st = s.run(); !st) return st;
  impl_->sessions.insert(id);
  *session = id;
  return Status::ok();
}

Status LandmarkStore::writeBatch(const StoreBatch& batch) {
  if (mode_ == OpenMode::kReadOnly) {
    return Status::error("map '" + path_ + "' is open read-only: cannot write");
  }
  Impl& impl = *impl_;
  uint64_t next_id = impl.next_landmark_id;
  for (const StoredLandmark& l : batch.upserts) {
    if (l.id > kMaxId) {
      return Status::error("map '" + path_ + "': landmark id " + std::to_string(l.id) +
                           " is >= 2^63");
    }
    if (!l.p_m.allFinite()) {
      return Status::error("map '" + path_ + "': landmark " + std::to_string(l.id) +
                           " has a non-finite position");
    }
    if (impl.sessions.count(l.session) == 0) {
      return Status::error("map '" + path_ + "': landmark " + std::to_string(l.id) +
                           " names session " + std::to_string(l.session) +
                           ", which the store does not hold (beginSession)");
    }
    next_id = std::max(next_id, l.id + 1);
  }
  for (const StoredKeyframe& k : batch.keyframes) {
    if (impl.sessions.count(k.session) == 0) {
      return Status::error("map '" + path_ + "': keyframe " + std::to_string(k.frame) +
                           " names session " + std::to_string(k.session) +
                           ", which the store does not hold (beginSession)");
    }
  }
  if (Status st = impl.db.exec("BEGIN IMMEDIATE"); !st) return st;
  auto write = [&]() -> Status {
    for (const StoredLandmark& l : batch.upserts) {
      // A landmark seen again keeps its position (confirmed landmarks are not re-refined): its
      // R*Tree entry, most of an upsert's cost, is then left as it is.
      SqliteStatement& p = impl.select_position;
      p.bindInt(1, static_cast<int64_t>(l.id));
      const bool unmoved = p.step() == SqliteStatement::StepResult::kRow &&
                           p.columnDouble(0) == l.p_m.x() && p.columnDouble(1) == l.p_m.y() &&
                           p.columnDouble(2) == l.p_m.z();
      p.reset();
      SqliteStatement& s = impl.upsert_landmark;
      s.bindInt(1, static_cast<int64_t>(l.id));
      s.bindDouble(2, l.p_m.x());
      s.bindDouble(3, l.p_m.y());
      s.bindDouble(4, l.p_m.z());
      s.bindBlob(5, l.cov_m.data(), sizeof(double) * 9);
      s.bindDouble(6, l.confidence);
      s.bindInt(7, l.observations);
      s.bindInt(8, l.session);
      s.bindInt(9, l.first_seen_frame);
      s.bindInt(10, l.last_seen_frame);
      s.bindInt(11, l.first_seen_t_ns);
      s.bindInt(12, l.last_seen_t_ns);
      s.bindInt(13, l.descriptor_kind);
      s.bindBlob(14, l.descriptor.data(), l.descriptor.size());
      if (Status st = s.run(); !st) return st;
      if (unmoved) continue;
      SqliteStatement& r = impl.upsert_rtree;
      r.bindInt(1, static_cast<int64_t>(l.id));
      r.bindDouble(2, l.p_m.x());
      r.bindDouble(3, l.p_m.y());
      r.bindDouble(4, l.p_m.z());
      if (Status st = r.run(); !st) return st;
    }
    for (const uint64_t id : batch.removed) {
      if (id > kMaxId) continue;  // never stored
      impl.delete_landmark.bindInt(1, static_cast<int64_t>(id));
      if (Status st = impl.delete_landmark.run(); !st) return st;
      impl.delete_rtree.bindInt(1, static_cast<int64_t>(id));
      if (Status st = impl.delete_rtree.run(); !st) return st;
    }
    for (const StoredKeyframe& k : batch.keyframes) {
      SqliteStatement& s = impl.upsert_keyframe;
      const Eigen::Quaterniond q(k.T_m_b.rotation());
      s.bindInt(1, k.session);
      s.bindInt(2, k.frame);
      s.bindInt(3, k.t_ns);
      s.bindDouble(4, k.T_m_b.translation().x());
      s.bindDouble(5, k.T_m_b.translation().y());
      s.bindDouble(6, k.T_m_b.translation().z());
      s.bindDouble(7, q.w());
      s.bindDouble(8, q.x());
      s.bindDouble(9, q.y());
      s.bindDouble(10, q.z());
      if (Status st = s.run(); !st) return st;
    }
    if (next_id != impl.next_landmark_id) {
      if (Status st = impl.setMeta("next_landmark_id", std::to_string(next_id)); !st) return st;
    }
    return impl.db.exec("COMMIT");
  };
  if (Status st = write(); !st) {
    static_cast<void>(impl.db.exec("ROLLBACK"));  // the error that matters is st
    return st;
  }
  impl.next_landmark_id = next_id;
  return Status::ok();
}

Status LandmarkStore::loadAll(std::vector<StoredLandmark>* out) const {
  out->clear();
  return impl_->selectLandmarks(
      std::string("SELECT ") + kLandmarkColumns + " FROM landmarks AS l ORDER BY l.id", {}, out);
}

Status LandmarkStore::queryBox(const Eigen::Vector3d& min_m,
                               const Eigen::Vector3d& max_m,
                               std::vector<StoredLandmark>* out) const {
  out->clear();
  if (Status st = checkBox(path_, min_m, max_m); !st) return st;
  // The R*Tree holds 32-bit float boxes rounded outwards, so it returns a superset of the
  // answer; the exact test is on the double positions. CROSS JOIN keeps the R*Tree outermost.
  std::vector<StoredLandmark> candidates;
  if (Status st = impl_->selectLandmarks(
          std::string("SELECT ") + kLandmarkColumns +
              " FROM landmark_rtree AS r CROSS JOIN landmarks AS l ON l.id = r.id WHERE " +
              kRtreeMeetsBox,
          {min_m.x(), max_m.x(), min_m.y(), max_m.y(), min_m.z(), max_m.z()},
          &candidates);
      !st) {
    return st;
  }
  for (StoredLandmark& l : candidates) {
    if ((l.p_m.array() >= min_m.array()).all() && (l.p_m.array() <= max_m.array()).all()) {
      out->push_back(std::move(l));
    }
  }
  std::sort(out->begin(), out->end(), [](const StoredLandmark& a, const StoredLandmark& b) {
    return a.id < b.id;
  });
  return Status::ok();
}

Status LandmarkStore::queryBoxIds(const Eigen::Vector3d& min_m,
                                  const Eigen::Vector3d& max_m,
                                  std::vector<uint64_t>* ids) const {
  ids->clear();
  if (Status st = checkBox(path_, min_m, max_m); !st) return st;
  SqliteStatement s;
  if (Status st = s.prepare(
          impl_->db, std::string("SELECT r.id FROM landmark_rtree AS r WHERE ") + kRtreeMeetsBox);
      !st) {
    return st;
  }
  const double bounds[6] = {min_m.x(), max_m.x(), min_m.y(), max_m.y(), min_m.z(), max_m.z()};
  for (int i = 0; i < 6; ++i) s.bindDouble(i + 1, bounds[i]);
  SqliteStatement::StepResult r;
  while ((r = s.step()) == SqliteStatement::StepResult::kRow)
    ids->push_back(static_cast<uint64_t>(s.columnInt(0)));
  if (r == SqliteStatement::StepResult::kError) return s.error("failed");
  std::sort(ids->begin(), ids->end());
  return Status::ok();
}

Status LandmarkStore::loadByIds(const std::vector<uint64_t>& ids,
                                std::vector<StoredLandmark>* out) const {
  out->clear();
  if (ids.empty()) return Status::ok();
  SqliteStatement s;
  if (Status st = s.prepare(
          impl_->db,
          std::string("SELECT ") + kLandmarkColumns + " FROM landmarks AS l WHERE l.id = ?1");
      !st) {
    return st;
  }
  out->reserve(ids.size());
  for (uint64_t id : ids) {
    s.reset();
    s.bindInt(1, static_cast<int64_t>(id));
    const SqliteStatement::StepResult r = s.step();
    if (r == SqliteStatement::StepResult::kError) return s.error("failed");
    if (r != SqliteStatement::StepResult::kRow) {
      return Status::error("map '" + path_ + "': no landmark " + std::to_string(id));
    }
    out->push_back(readLandmark(s));
  }
  return Status::ok();
}

Status LandmarkStore::queryRadius(const Eigen::Vector3d& center_m,
                                  double radius_m,
                                  std::vector<StoredLandmark>* out) const {
  out->clear();
  if (!center_m.allFinite() || !std::isfinite(radius_m) || radius_m < 0.0) {
    std::ostringstream os;
    os << "map '" << path_ << "': query radius " << radius_m
       << " m; must be finite and >= 0 (and the center finite)";
    return Status::error(os.str());
  }
  const Eigen::Vector3d half = Eigen::Vector3d::Constant(radius_m);
  std::vector<StoredLandmark> in_box;
  if (Status st = queryBox(center_m - half, center_m + half, &in_box); !st) return st;
  const double r2 = radius_m * radius_m;
  for (StoredLandmark& l : in_box) {
    if ((l.p_m - center_m).squaredNorm() <= r2) out->push_back(std::move(l));
  }
  return Status::ok();
}

Status LandmarkStore::keyframes(int32_t session, std::vector<StoredKeyframe>* out) const {
  out->clear();
  SqliteStatement s;
  if (Status st = s.prepare(impl_->db,
                            "SELECT session, frame, t_ns, tx, ty, tz, qw, qx, qy, qz FROM "
                            "keyframes WHERE session = ?1 ORDER BY frame");
      !st) {
    return st;
  }
  s.bindInt(1, session);
  SqliteStatement::StepResult r;
  while ((r = s.step()) == SqliteStatement::StepResult::kRow) {
    StoredKeyframe k;
    k.session = static_cast<int32_t>(s.columnInt(0));
    k.frame = static_cast<int32_t>(s.columnInt(1));
    k.t_ns = s.columnInt(2);
    const Eigen::Vector3d t(s.columnDouble(3), s.columnDouble(4), s.columnDouble(5));
    const Eigen::Quaterniond q(
        s.columnDouble(6), s.columnDouble(7), s.columnDouble(8), s.columnDouble(9));
    k.T_m_b = Eigen::Isometry3d::Identity();
    k.T_m_b.linear() = q.normalized().toRotationMatrix();
    k.T_m_b.translation() = t;
    out->push_back(k);
  }
  if (r == SqliteStatement::StepResult::kError) return s.error("failed");
  return Status::ok();
}

Status LandmarkStore::info(StoreInfo* out) const {
  *out = StoreInfo{};
  Impl& impl = *impl_;
  int64_t version = 0;
  if (Status st = impl.db.queryInt("PRAGMA user_version", &version); !st) return st;
  out->schema_version = static_cast<int32_t>(version);
  {
    SqliteStatement m;
    if (Status st = m.prepare(impl.db, "SELECT key, value FROM meta"); !st) return st;
    while (m.step() == SqliteStatement::StepResult::kRow) {
      const std::string key = m.columnText(0);
      if (key == "created") out->created = m.columnText(1);
      if (key == "tool_version") out->tool_version = m.columnText(1);
      if (key == "next_landmark_id") out->next_landmark_id = std::stoull(m.columnText(1));
    }
  }
  {
    SqliteStatement s;
    if (Status st = s.prepare(
            impl.db, "SELECT id, rig, config, started, log_path FROM sessions ORDER BY id");
        !st) {
      return st;
    }
    SqliteStatement::StepResult r;
    while ((r = s.step()) == SqliteStatement::StepResult::kRow) {
      out->sessions.push_back({static_cast<int32_t>(s.columnInt(0)),
                               s.columnText(1),
                               s.columnText(2),
                               s.columnText(3),
                               s.columnText(4)});
    }
    if (r == SqliteStatement::StepResult::kError) return s.error("failed");
  }
  if (Status st = impl.db.queryInt("SELECT COUNT(*) FROM keyframes", &out->keyframe_count); !st) {
    return st;
  }
  SqliteStatement b;
  if (Status st = b.prepare(impl.db,
                            "SELECT COUNT(*), MIN(x), MIN(y), MIN(z), MAX(x), MAX(y), MAX(z) FROM "
                            "landmarks");
      !st) {
    return st;
  }
  if (b.step() != SqliteStatement::StepResult::kRow) return b.error("failed");
  out->landmark_count = b.columnInt(0);
  if (out->landmark_count > 0) {
    out->box_min_m = {b.columnDouble(1), b.columnDouble(2), b.columnDouble(3)};
    out->box_max_m = {b.columnDouble(4), b.columnDouble(5), b.columnDouble(6)};
  }
  std::error_code ec;
  const auto bytes = fs::file_size(path_, ec);
  out->file_bytes = ec ? 0 : static_cast<int64_t>(bytes);
  const auto wal = fs::file_size(path_ + "-wal", ec);
  out->wal_bytes = ec ? 0 : static_cast<int64_t>(wal);
  return Status::ok();
}

Status LandmarkStore::integrityCheck() const {
  std::vector<std::string> rows;
  if (Status st = impl_->db.queryTextColumn("PRAGMA integrity_check", &rows); !st) return st;
  if (rows.size() == 1 && rows[0] == "ok") return Status::ok();
  std::string findings;
  for (size_t i = 0; i < rows.size() && i < 3; ++i) findings += (i > 0 ? "; " : "") + rows[i];
  return Status::error("map '" + path_ + "' failed PRAGMA integrity_check: " + findings);
}

}  // namespace twocam::store
