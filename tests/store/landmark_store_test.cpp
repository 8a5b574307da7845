// The landmark store: round trips, spatial queries against brute force, sessions, every refusal
// with the file untouched, read-only mode, exports, and crash safety under SIGKILL.

#include "store/landmark_store.h"

#include <gtest/gtest.h>
#include <mrpt/maps/CSimplePointsMap.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "store/store_export.h"
#include "support/command.h"
#include "support/test_paths.h"

namespace twocam::store {
namespace {

namespace fs = std::filesystem;

constexpr uint64_t kSeed = 20261203;
/// Keyframe rotations go through a unit quaternion: a few ulps of the matrix entries.
constexpr double kPoseRoundTripTol = 1e-12;
/// MRPT keeps points as float: relative rounding 2^-24 of coordinates up to 60 m, plus the
/// text format's printed digits.
constexpr double kMrptPointTol = 1e-4;

std::unique_ptr<LandmarkStore> openOrDie(const std::string& path, OpenMode mode) {
  std::unique_ptr<LandmarkStore> store;
  const Status st = LandmarkStore::open(path, mode, &store);
  EXPECT_TRUE(st.isOk()) << st.message();
  return store;
}

int32_t beginOrDie(LandmarkStore& store, const std::string& log = "log.rawlog") {
  int32_t session = -1;
  const Status st = store.beginSession("rig: test", "config: test", log, &session);
  EXPECT_TRUE(st.isOk()) << st.message();
  return session;
}

StoredLandmark randomLandmark(std::mt19937_64& rng, uint64_t id, int32_t session) {
  std::uniform_real_distribution<double> xy(-50.0, 50.0), z(0.0, 5.0), unit(0.0, 1.0);
  std::uniform_int_distribution<int> frame(0, 10000), bytes(0, 255), len(0, 64);
  StoredLandmark l;
  l.id = id;
  l.p_m = {xy(rng), xy(rng), z(rng)};
  Eigen::Matrix3d a;
  for (int i = 0; i < 9; ++i) a.data()[i] = unit(rng) - 0.5;
  l.cov_m = a * a.transpose() * 1e-3;
  l.confidence = unit(rng);
  l.observations = frame(rng);
  l.session = session;
  l.first_seen_frame = frame(rng);
  l.last_seen_frame = l.first_seen_frame + frame(rng);
  l.first_seen_t_ns = static_cast<int64_t>(l.first_seen_frame) * 33'000'000 + 17;
  l.last_seen_t_ns = static_cast<int64_t>(l.last_seen_frame) * 33'000'000 + 5'000'000'000'000LL;
  l.descriptor_kind = static_cast<uint8_t>(bytes(rng));
  l.descriptor.resize(static_cast<size_t>(len(rng)));
  for (uint8_t& b : l.descriptor) b = static_cast<uint8_t>(bytes(rng));
  return l;
}

StoredKeyframe randomKeyframe(std::mt19937_64& rng, int32_t session, int32_t frame) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  StoredKeyframe k;
  k.session = session;
  k.frame = frame;
  k.t_ns = static_cast<int64_t>(frame) * 33'333'333;
  const Eigen::Quaterniond q = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
  k.T_m_b = Eigen::Isometry3d::Identity();
  k.T_m_b.linear() = q.toRotationMatrix();
  k.T_m_b.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 40.0;
  return k;
}

void expectSame(const StoredLandmark& a, const StoredLandmark& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.p_m, b.p_m) << "id " << a.id;  // REAL columns hold the exact double
  EXPECT_EQ(a.cov_m, b.cov_m) << "id " << a.id;
  EXPECT_EQ(a.confidence, b.confidence);
  EXPECT_EQ(a.observations, b.observations);
  EXPECT_EQ(a.session, b.session);
  EXPECT_EQ(a.first_seen_frame, b.first_seen_frame);
  EXPECT_EQ(a.last_seen_frame, b.last_seen_frame);
  EXPECT_EQ(a.first_seen_t_ns, b.first_seen_t_ns);
  EXPECT_EQ(a.last_seen_t_ns, b.last_seen_t_ns);
  EXPECT_EQ(a.descriptor_kind, b.descriptor_kind);
  EXPECT_EQ(a.descriptor, b.descriptor) << "id " << a.id;
}

std::string fileBytes(const std::string& path) { return test::readFile(path); }

std::vector<uint64_t> ids(const std::vector<StoredLandmark>& landmarks) {
  std::vector<uint64_t> out;
  for (const StoredLandmark& l : landmarks) out.push_back(l.id);
  return out;
}

/// A store with `n` random landmarks of one session, closed (its log checkpointed into it).
std::vector<StoredLandmark> makeStore(const std::string& path, int n, uint64_t seed = kSeed) {
  std::mt19937_64 rng(seed);
  auto store = openOrDie(path, OpenMode::kCreateOrExtend);
  if (!store) return {};
  const int32_t session = beginOrDie(*store);
  StoreBatch batch;
  for (int i = 0; i < n; ++i) batch.upserts.push_back(randomLandmark(rng, 1 + i, session));
  batch.keyframes.push_back(randomKeyframe(rng, session, 0));
  const Status st = store->writeBatch(batch);
  EXPECT_TRUE(st.isOk()) << st.message();
  return batch.upserts;
}

/// Runs SQL on a file with the plain sqlite3 API (to build foreign or altered files).
void rawSql(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* message = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &message);
  EXPECT_EQ(rc, SQLITE_OK) << (message != nullptr ? message : "");
  sqlite3_free(message);
  sqlite3_close(db);
}

// ---------------------------------------------------------------------------------------------

TEST(LandmarkStore, RoundTripsEveryField) {
  const std::string path = test::makeTempDir("store_round_trip") + "/map.db";
  std::mt19937_64 rng(kSeed);
  std::vector<StoredLandmark> written;
  std::vector<StoredKeyframe> keyframes;
  {
    auto store = openOrDie(path, OpenMode::kCreateOrExtend);
    ASSERT_TRUE(store);
    const int32_t session = beginOrDie(*store, "/data/office.rawlog");
    EXPECT_EQ(session, 1);
    StoreBatch batch;
    for (uint64_t id : {7u, 3u, 1000u, 42u, 5u})
      batch.upserts.push_back(randomLandmark(rng, id, session));
    batch.upserts[1].descriptor.clear();        // an empty descriptor stays empty
    batch.upserts[2].descriptor.assign(32, 0);  // zeros are bytes, not a terminator
    for (int f = 0; f < 4; ++f) batch.keyframes.push_back(randomKeyframe(rng, session, 10 * f));
    ASSERT_TRUE(store->writeBatch(batch).isOk());
    written = batch.upserts;
    keyframes = batch.keyframes;
  }
  auto store = openOrDie(path, OpenMode::kReadOnly);
  ASSERT_TRUE(store);
  std::vector<StoredLandmark> loaded;
  ASSERT_TRUE(store->loadAll(&loaded).isOk());
  std::sort(written.begin(), written.end(), [](auto& a, auto& b) { return a.id < b.id; });
  ASSERT_EQ(loaded.size(), written.size());
  for (size_t i = 0; i < loaded.size(); ++i) expectSame(loaded[i], written[i]);

  std::vector<StoredKeyframe> loaded_kf;
  ASSERT_TRUE(store->keyframes(1, &loaded_kf).isOk());
  ASSERT_EQ(loaded_kf.size(), keyframes.size());
  for (size_t i = 0; i < keyframes.size(); ++i) {
    EXPECT_EQ(loaded_kf[i].session, keyframes[i].session);
    EXPECT_EQ(loaded_kf[i].frame, keyframes[i].frame);
    EXPECT_EQ(loaded_kf[i].t_ns, keyframes[i].t_ns);
    EXPECT_TRUE(
        loaded_kf[i].T_m_b.matrix().isApprox(keyframes[i].T_m_b.matrix(), kPoseRoundTripTol))
        << loaded_kf[i].T_m_b.matrix() << "\nvs\n"
        << keyframes[i].T_m_b.matrix();
  }
  std::vector<StoredKeyframe> none;
  ASSERT_TRUE(store->keyframes(2, &none).isOk());
  EXPECT_TRUE(none.empty());

  StoreInfo info;
  ASSERT_TRUE(store->info(&info).isOk());
  EXPECT_EQ(info.schema_version, kStoreSchemaVersion);
  EXPECT_EQ(info.landmark_count, 5);
  EXPECT_EQ(info.keyframe_count, 4);
  EXPECT_EQ(info.next_landmark_id, 1001u);
  ASSERT_EQ(info.sessions.size(), 1u);
  EXPECT_EQ(info.sessions[0].id, 1);
  EXPECT_EQ(info.sessions[0].rig_text, "rig: test");
  EXPECT_EQ(info.sessions[0].config_text, "config: test");
  EXPECT_EQ(info.sessions[0].log_path, "/data/office.rawlog");
  EXPECT_EQ(info.sessions[0].started.size(), std::string("2026-12-03T17:04:05Z").size());
  EXPECT_FALSE(info.created.empty());
  EXPECT_NE(info.tool_version.find("twocam"), std::string::npos);
  Eigen::Vector3d lo = written[0].p_m, hi = written[0].p_m;
  for (const auto& l : written) {
    lo = lo.cwiseMin(l.p_m);
    hi = hi.cwiseMax(l.p_m);
  }
  EXPECT_EQ(info.box_min_m, lo);
  EXPECT_EQ(info.box_max_m, hi);
  EXPECT_EQ(info.file_bytes, static_cast<int64_t>(fs::file_size(path)));
  EXPECT_TRUE(store->integrityCheck().isOk());
}

TEST(LandmarkStore, UpsertReplacesAndRemoveDeletesInOneBatch) {
  const std::string path = test::makeTempDir("store_upsert") + "/map.db";
  std::mt19937_64 rng(kSeed);
  auto store = openOrDie(path, OpenMode::kCreateOrExtend);
  ASSERT_TRUE(store);
  const int32_t s = beginOrDie(*store);
  std::map<uint64_t, StoredLandmark> expected;
  StoreBatch first;
  for (uint64_t id = 1; id <= 20; ++id) first.upserts.push_back(randomLandmark(rng, id, s));
  ASSERT_TRUE(store->writeBatch(first).isOk());
  for (const auto& l : first.upserts) expected[l.id] = l;

  StoreBatch second;
  for (uint64_t id : {2u, 4u, 25u}) second.upserts.push_back(randomLandmark(rng, id, s));
  second.removed = {4, 9, 11, 999};  // 4 is upserted then removed: removals come last
  ASSERT_TRUE(store->writeBatch(second).isOk());
  for (const auto& l : second.upserts) expected[l.id] = l;
  for (uint64_t id : second.removed) expected.erase(id);

  std::vector<StoredLandmark> loaded;
  ASSERT_TRUE(store->loadAll(&loaded).isOk());
  ASSERT_EQ(loaded.size(), expected.size());
  size_t i = 0;
  for (const auto& [id, l] : expected) expectSame(loaded[i++], l);
  // The index follows the table: a removed landmark is not found by a query around it.
  std::vector<StoredLandmark> near;
  ASSERT_TRUE(store->queryRadius(first.upserts[8].p_m, 1e-3, &near).isOk());
  for (const auto& l : near) EXPECT_NE(l.id, 9u);
  ASSERT_TRUE(store->queryRadius(second.upserts[0].p_m, 0.0, &near).isOk());
  ASSERT_EQ(near.size(), 1u);
  EXPECT_EQ(near[0].id, 2u);
  // Landmark 2 moved: not found where it was.
  ASSERT_TRUE(store->queryRadius(first.upserts[1].p_m, 0.0, &near).isOk());
  EXPECT_TRUE(near.empty());
  // Seen again without moving (only the counts change): the index still finds it, with the new
  // fields.
  StoreBatch third;
  third.upserts = {expected[3]};
  third.upserts[0].observations += 1;
  third.upserts[0].last_seen_frame += 7;
  ASSERT_TRUE(store->writeBatch(third).isOk());
  ASSERT_TRUE(store->queryRadius(expected[3].p_m, 0.0, &near).isOk());
  ASSERT_EQ(near.size(), 1u);
  expectSame(near[0], third.upserts[0]);
  ASSERT_TRUE(store->integrityCheck().isOk());
}

TEST(LandmarkStore, RejectsBadBatchesAndWritesNothing) {
  const std::string path = test::makeTempDir("store_bad_batch") + "/map.db";
  std::mt19937_64 rng(kSeed);
  auto store = openOrDie(path, OpenMode::kCreateOrExtend);
  ASSERT_TRUE(store);
  const int32_t s = beginOrDie(*store);
  const auto count = [&] {
    StoreInfo info;
    EXPECT_TRUE(store->info(&info).isOk());
    return info.landmark_count + info.keyframe_count;
  };
  StoreBatch nan;
  nan.upserts = {randomLandmark(rng, 1, s), randomLandmark(rng, 2, s)};
  nan.upserts[1].p_m.y() = std::nan("");
  Status st = store->writeBatch(nan);
  EXPECT_FALSE(st.isOk());
  EXPECT_NE(st.message().find("non-finite"), std::string::npos) << st.message();
  StoreBatch unknown_session;
  unknown_session.upserts = {randomLandmark(rng, 1, s + 1)};
  st = store->writeBatch(unknown_session);
  EXPECT_NE(st.message().find("session 2"), std::string::npos) << st.message();
  StoreBatch unknown_kf_session;
  unknown_kf_session.keyframes = {randomKeyframe(rng, 7, 1)};
  EXPECT_FALSE(store->writeBatch(unknown_kf_session).isOk());
  StoreBatch huge_id;
  huge_id.upserts = {randomLandmark(rng, uint64_t{1} << 63, s)};
  EXPECT_FALSE(store->writeBatch(huge_id).isOk());
  EXPECT_EQ(count(), 0);
  std::vector<StoredLandmark> out;
  EXPECT_FALSE(store->queryRadius(Eigen::Vector3d::Zero(), -1.0, &out).isOk());
}

TEST(LandmarkStore, SpatialQueriesEqualBruteForce) {
  constexpr int kLandmarks = 5000;
  constexpr int kQueries = 300;
  const std::string path = test::makeTempDir("store_queries") + "/map.db";
  const std::vector<StoredLandmark> all = makeStore(path, kLandmarks);
  auto store = openOrDie(path, OpenMode::kReadOnly);
  ASSERT_TRUE(store);
  std::mt19937_64 rng(kSeed + 1);
  std::uniform_real_distribution<double> xy(-60.0, 60.0), z(-1.0, 6.0), r(0.0, 15.0),
      half(0.0, 12.0);
  std::uniform_int_distribution<int> pick(0, kLandmarks - 1);
  size_t total_found = 0;
  for (int q = 0; q < kQueries; ++q) {
    // Every tenth query is centred on (or has a corner at) a landmark: boundary cases.
    const bool on_point = q % 10 == 0;
    const Eigen::Vector3d c =
        on_point ? all[pick(rng)].p_m : Eigen::Vector3d(xy(rng), xy(rng), z(rng));
    const double radius = r(rng);
    std::vector<uint64_t> want;
    for (const auto& l : all) {
      if ((l.p_m - c).squaredNorm() <= radius * radius) want.push_back(l.id);
    }
    std::vector<StoredLandmark> got;
    ASSERT_TRUE(store->queryRadius(c, radius, &got).isOk());
    EXPECT_EQ(ids(got), want) << "radius query " << q;
    total_found += want.size();

    const Eigen::Vector3d lo = on_point ? c : c - Eigen::Vector3d(half(rng), half(rng), half(rng));
    const Eigen::Vector3d hi = c + Eigen::Vector3d(half(rng), half(rng), half(rng));
    want.clear();
    for (const auto& l : all) {
      if ((l.p_m.array() >= lo.array()).all() && (l.p_m.array() <= hi.array()).all()) {
        want.push_back(l.id);
      }
    }
    ASSERT_TRUE(store->queryBox(lo, hi, &got).isOk());
    EXPECT_EQ(ids(got), want) << "box query " << q;
    // The index alone: every id of the answer, and any other only within a float rounding of
    // the box; the rows by id are the rows.
    std::vector<uint64_t> index_ids;
    ASSERT_TRUE(store->queryBoxIds(lo, hi, &index_ids).isOk());
    EXPECT_TRUE(std::includes(index_ids.begin(), index_ids.end(), want.begin(), want.end()))
        << "box ids " << q;
    std::vector<StoredLandmark> by_id;
    ASSERT_TRUE(store->loadByIds(index_ids, &by_id).isOk());
    ASSERT_EQ(by_id.size(), index_ids.size());
    for (const StoredLandmark& l : by_id) {
      const Eigen::Array3d slack = 1e-6 * (1.0 + l.p_m.array().abs());
      EXPECT_TRUE((l.p_m.array() >= lo.array() - slack).all() &&
                  (l.p_m.array() <= hi.array() + slack).all())
          << "box ids " << q << ": landmark " << l.id << " at " << l.p_m.transpose();
      EXPECT_EQ(l.p_m, all[static_cast<size_t>(l.id - all.front().id)].p_m);
    }
    if (on_point) {
      EXPECT_FALSE(want.empty());
    }
    total_found += want.size();
  }
  EXPECT_GT(total_found, static_cast<size_t>(kQueries) * 10);  // the queries are not all empty
  // An id not in the map is an error naming it.
  std::vector<StoredLandmark> none;
  const Status missing = store->loadByIds({all[5].id, 999999}, &none);
  EXPECT_FALSE(missing.isOk());
  EXPECT_NE(missing.message().find("no landmark 999999"), std::string::npos) << missing.message();
  // A radius-0 query on a landmark finds exactly it.
  std::vector<StoredLandmark> got;
  ASSERT_TRUE(store->queryRadius(all[123].p_m, 0.0, &got).isOk());
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].id, all[123].id);
}

TEST(LandmarkStore, ReopenAndExtendContinuesIdsAndKeepsTheFirstSession) {
  const std::string path = test::makeTempDir("store_extend") + "/map.db";
  const std::vector<StoredLandmark> first = makeStore(path, 100);
  std::mt19937_64 rng(kSeed + 2);
  {
    auto store = openOrDie(path, OpenMode::kCreateOrExtend);
    ASSERT_TRUE(store);
    StoreInfo info;
    ASSERT_TRUE(store->info(&info).isOk());
    EXPECT_EQ(info.next_landmark_id, 101u);
    const int32_t s2 = beginOrDie(*store, "second.rawlog");
    EXPECT_EQ(s2, 2);
    StoreBatch batch;
    for (uint64_t id = info.next_landmark_id; id < info.next_landmark_id + 50; ++id) {
      batch.upserts.push_back(randomLandmark(rng, id, s2));
    }
    batch.keyframes.push_back(randomKeyframe(rng, s2, 0));
    ASSERT_TRUE(store->writeBatch(batch).isOk());
  }
  auto store = openOrDie(path, OpenMode::kReadOnly);
  ASSERT_TRUE(store);
  StoreInfo info;
  ASSERT_TRUE(store->info(&info).isOk());
  EXPECT_EQ(info.landmark_count, 150);
  EXPECT_EQ(info.keyframe_count, 2);
  EXPECT_EQ(info.next_landmark_id, 151u);
  ASSERT_EQ(info.sessions.size(), 2u);
  EXPECT_EQ(info.sessions[0].log_path, "log.rawlog");
  EXPECT_EQ(info.sessions[1].log_path, "second.rawlog");
  std::vector<StoredLandmark> loaded;
  ASSERT_TRUE(store->loadAll(&loaded).isOk());
  ASSERT_EQ(loaded.size(), 150u);
  for (size_t i = 0; i < first.size(); ++i) expectSame(loaded[i], first[i]);
  for (size_t i = first.size(); i < loaded.size(); ++i) EXPECT_EQ(loaded[i].session, 2);
}

TEST(LandmarkStore, AReaderSeesEachCommitWhileTheWriterIsOpen) {
  const std::string path = test::makeTempDir("store_reader_writer") + "/map.db";
  std::mt19937_64 rng(kSeed);
  auto writer = openOrDie(path, OpenMode::kCreateOrExtend);
  ASSERT_TRUE(writer);
  const int32_t s = beginOrDie(*writer);
  auto reader = openOrDie(path, OpenMode::kReadOnly);
  ASSERT_TRUE(reader);
  for (int batch = 1; batch <= 3; ++batch) {
    StoreBatch b;
    for (int i = 0; i < 10; ++i) b.upserts.push_back(randomLandmark(rng, batch * 100 + i, s));
    ASSERT_TRUE(writer->writeBatch(b).isOk());
    StoreInfo info;
    ASSERT_TRUE(reader->info(&info).isOk());
    EXPECT_EQ(info.landmark_count, 10 * batch);
    EXPECT_GT(info.wal_bytes, 0);  // the commits are in the log until a checkpoint
  }
}

// --- refusals: a clear error naming the path, the file's bytes unchanged ----------------------

void expectRefused(const std::string& path, const std::string& expected_phrase) {
  const std::string before = fileBytes(path);
  ASSERT_FALSE(before.empty());
  for (OpenMode mode : {OpenMode::kReadOnly, OpenMode::kCreateOrExtend}) {
    std::unique_ptr<LandmarkStore> store;
    const Status st = LandmarkStore::open(path, mode, &store);
    EXPECT_FALSE(st.isOk()) << path;
    EXPECT_FALSE(store);
    EXPECT_NE(st.message().find(path), std::string::npos) << st.message();
    EXPECT_NE(st.message().find(expected_phrase), std::string::npos) << st.message();
  }
  EXPECT_EQ(fileBytes(path), before) << path << " was modified";
  EXPECT_FALSE(fs::exists(path + "-wal") && fs::file_size(path + "-wal") > 0) << path;
}

TEST(LandmarkStore, RefusesAFileThatIsNotSqlite) {
  const std::string dir = test::makeTempDir("store_refuse_text");
  const std::string path = dir + "/notes.db";
  std::ofstream(path) << "landmarks: [1, 2, 3]\nthis is not a database\n";
  expectRefused(path, "not an SQLite database");
  const std::string empty = dir + "/empty.db";
  std::ofstream(empty).flush();
  for (OpenMode mode : {OpenMode::kReadOnly, OpenMode::kCreateOrExtend}) {
    std::unique_ptr<LandmarkStore> store;
    const Status st = LandmarkStore::open(empty, mode, &store);
    EXPECT_NE(st.message().find("is empty"), std::string::npos) << st.message();
  }
  EXPECT_EQ(fs::file_size(empty), 0u);
}

TEST(LandmarkStore, RefusesAnSqliteFileThatIsNotAStore) {
  const std::string path = test::makeTempDir("store_refuse_foreign") + "/other.db";
  rawSql(path, "CREATE TABLE t(x INTEGER); INSERT INTO t VALUES(1), (2);");
  expectRefused(path, "not a TwoCam landmark store");
}

TEST(LandmarkStore, RefusesANewerAndAnUnknownSchemaVersion) {
  const std::string dir = test::makeTempDir("store_refuse_version");
  const std::string newer = dir + "/newer.db";
  makeStore(newer, 10);
  rawSql(newer, "PRAGMA user_version=" + std::to_string(kStoreSchemaVersion + 1));
  expectRefused(newer, "newer than this twocam reads");
  const std::string unknown = dir + "/unknown.db";
  makeStore(unknown, 10);
  rawSql(unknown, "PRAGMA user_version=0");
  expectRefused(unknown, "unknown schema version 0");
}

TEST(LandmarkStore, RefusesACorruptFile) {
  const std::string dir = test::makeTempDir("store_refuse_corrupt");
  constexpr size_t kPageBytes = 4096;  // SQLite's default page size
  // Pages 3..6 overwritten with seeded noise.
  const std::string garbled = dir + "/garbled.db";
  makeStore(garbled, 3000);
  {
    std::string bytes = fileBytes(garbled);
    ASSERT_GT(bytes.size(), 8 * kPageBytes);
    std::mt19937 rng(kSeed);
    for (size_t i = 2 * kPageBytes; i < 6 * kPageBytes; ++i) bytes[i] = static_cast<char>(rng());
    std::ofstream(garbled, std::ios::binary | std::ios::trunc) << bytes;
  }
  expectRefused(garbled, "corrupt");
  // Cut in half.
  const std::string truncated = dir + "/truncated.db";
  makeStore(truncated, 3000);
  fs::resize_file(truncated, fs::file_size(truncated) / 2);
  expectRefused(truncated, "corrupt");
}

TEST(LandmarkStore, MissingPathIsAnErrorReadOnlyAndCreatedOtherwise) {
  const std::string dir = test::makeTempDir("store_missing");
  std::unique_ptr<LandmarkStore> store;
  Status st = LandmarkStore::open(dir + "/absent.db", OpenMode::kReadOnly, &store);
  EXPECT_FALSE(st.isOk());
  EXPECT_NE(st.message().find(dir + "/absent.db"), std::string::npos) << st.message();
  EXPECT_FALSE(fs::exists(dir + "/absent.db"));
  st = LandmarkStore::open(dir + "/no_folder/map.db", OpenMode::kCreateOrExtend, &store);
  EXPECT_NE(st.message().find("does not exist"), std::string::npos) << st.message();
  std::ofstream(dir + "/orphan.db-wal") << "log of a deleted map";
  st = LandmarkStore::open(dir + "/orphan.db", OpenMode::kCreateOrExtend, &store);
  EXPECT_NE(st.message().find("write-ahead log"), std::string::npos) << st.message();
  EXPECT_FALSE(fs::exists(dir + "/orphan.db"));
  fs::remove(dir + "/orphan.db-wal");
  st = LandmarkStore::open(dir + "/new.db", OpenMode::kCreateOrExtend, &store);
  ASSERT_TRUE(st.isOk()) << st.message();
  EXPECT_TRUE(store->integrityCheck().isOk());
  store.reset();
  // Only the store is left in the folder (no temporary of the creation).
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  EXPECT_EQ(names, std::set<std::string>{"new.db"});
}

TEST(LandmarkStore, ReadOnlyModeNeverWrites) {
  const std::string path = test::makeTempDir("store_read_only") + "/map.db";
  const std::vector<StoredLandmark> all = makeStore(path, 500);
  const std::string before = fileBytes(path);
  {
    auto store = openOrDie(path, OpenMode::kReadOnly);
    ASSERT_TRUE(store);
    std::vector<StoredLandmark> out;
    EXPECT_TRUE(store->loadAll(&out).isOk());
    EXPECT_EQ(out.size(), all.size());
    EXPECT_TRUE(store->queryRadius(all[0].p_m, 5.0, &out).isOk());
    StoreInfo info;
    EXPECT_TRUE(store->info(&info).isOk());
    EXPECT_TRUE(store->integrityCheck().isOk());
    int32_t session = 0;
    Status st = store->beginSession("r", "c", "l", &session);
    EXPECT_NE(st.message().find("read-only"), std::string::npos) << st.message();
    StoreBatch batch;
    batch.removed = {1, 2, 3};
    st = store->writeBatch(batch);
    EXPECT_NE(st.message().find("read-only"), std::string::npos) << st.message();
  }
  EXPECT_EQ(fileBytes(path), before);
  EXPECT_FALSE(fs::exists(path + "-wal") && fs::file_size(path + "-wal") > 0);
}

// --- exports -----------------------------------------------------------------------------------

struct PlyFile {
  std::string format;
  size_t vertices = 0;
  std::vector<std::string> properties;
  std::vector<Eigen::Vector4d> rows;  // x y z confidence
};

PlyFile readPly(const std::string& path) {
  PlyFile ply;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "ply");
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") ls >> ply.format;
    if (word == "element") {
      std::string name;
      ls >> name >> ply.vertices;
      EXPECT_EQ(name, "vertex");
    }
    if (word == "property") {
      std::string type, name;
      ls >> type >> name;
      ply.properties.push_back(type + " " + name);
    }
  }
  EXPECT_EQ(line, "end_header");
  for (size_t i = 0; i < ply.vertices; ++i) {
    Eigen::Vector4d row;
    if (ply.format == "ascii") {
      in >> row[0] >> row[1] >> row[2] >> row[3];
    } else {
      double xyz[3];
      float c = 0;
      in.read(reinterpret_cast<char*>(xyz), sizeof(xyz));
      in.read(reinterpret_cast<char*>(&c), sizeof(c));
      row << xyz[0], xyz[1], xyz[2], c;
    }
    EXPECT_TRUE(in) << "vertex " << i << " of " << ply.vertices;
    ply.rows.push_back(row);
  }
  if (ply.format != "ascii") {
    char extra = 0;
    EXPECT_FALSE(in.read(&extra, 1)) << "bytes after the last vertex";
  } else {
    std::string rest;
    in >> rest;
    EXPECT_TRUE(rest.empty()) << "text after the last vertex: " << rest;
  }
  return ply;
}

TEST(StoreExport, PlyHeaderAndVerticesParseBack) {
  const std::string dir = test::makeTempDir("store_ply");
  const std::vector<StoredLandmark> all = makeStore(dir + "/map.db", 321);
  auto store = openOrDie(dir + "/map.db", OpenMode::kReadOnly);
  ASSERT_TRUE(store);
  for (PlyFormat format : {PlyFormat::kBinaryLittleEndian, PlyFormat::kAscii}) {
    const std::string out = dir + (format == PlyFormat::kAscii ? "/a.ply" : "/b.ply");
    const Status st = exportPly(*store, out, format);
    ASSERT_TRUE(st.isOk()) << st.message();
    const PlyFile ply = readPly(out);
    EXPECT_EQ(ply.format, format == PlyFormat::kAscii ? "ascii" : "binary_little_endian");
    EXPECT_EQ(ply.properties,
              (std::vector<std::string>{"double x", "double y", "double z", "float confidence"}));
    ASSERT_EQ(ply.vertices, all.size());
    ASSERT_EQ(ply.rows.size(), all.size());
    for (size_t i = 0; i < all.size(); ++i) {
      // 17 significant digits (ASCII) or the raw double (binary) give back the exact value.
      EXPECT_EQ(ply.rows[i].head<3>(), all[i].p_m) << i;
      EXPECT_EQ(static_cast<float>(ply.rows[i][3]), static_cast<float>(all[i].confidence));
    }
  }
}

TEST(StoreExport, MrptPointsMapLoadsBackWithTheSamePoints) {
  const std::string dir = test::makeTempDir("store_mrpt");
  const std::vector<StoredLandmark> all = makeStore(dir + "/map.db", 400);
  auto store = openOrDie(dir + "/map.db", OpenMode::kReadOnly);
  ASSERT_TRUE(store);
  const std::string out = dir + "/points.txt";
  const Status st = exportMrptPointsMap(*store, out);
  ASSERT_TRUE(st.isOk()) << st.message();
  mrpt::maps::CSimplePointsMap map;
  ASSERT_TRUE(map.load3D_from_text_file(out));
  ASSERT_EQ(map.size(), all.size());
  for (size_t i = 0; i < all.size(); ++i) {
    double x = 0, y = 0, z = 0;
    map.getPoint(i, x, y, z);
    EXPECT_NEAR(x, all[i].p_m.x(), kMrptPointTol) << i;
    EXPECT_NEAR(y, all[i].p_m.y(), kMrptPointTol) << i;
    EXPECT_NEAR(z, all[i].p_m.z(), kMrptPointTol) << i;
  }
}

TEST(StoreExport, AnUnwritableTargetIsAnErrorNamingItAndLeavesNothing) {
  const std::string dir = test::makeTempDir("store_export_error");
  const std::vector<StoredLandmark> all = makeStore(dir + "/map.db", 5);
  const std::string bad = dir + "/missing_folder/out.ply";
  Status st = exportPly(all, bad);
  EXPECT_FALSE(st.isOk());
  EXPECT_NE(st.message().find(bad), std::string::npos) << st.message();
  st = exportMrptPointsMap(all, dir + "/missing_folder/out.txt");
  EXPECT_NE(st.message().find("missing_folder/out.txt"), std::string::npos) << st.message();
  // An existing target is replaced only by the complete new file.
  const std::string existing = dir + "/old.ply";
  std::ofstream(existing) << "old";
  ASSERT_TRUE(exportPly(all, existing).isOk());
  EXPECT_EQ(readPly(existing).vertices, all.size());
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  EXPECT_EQ(names, (std::set<std::string>{"map.db", "old.ply"}));
}

// --- crash safety --------------------------------------------------------------------------------

/// Ids of frame f's new landmarks: f * kIdsPerFrame + i.
constexpr uint64_t kIdsPerFrame = 32;
constexpr int kNewPerFrame = 20;
constexpr int kUpdatedPerFrame = 3;
constexpr int kRemovedPerFrame = 2;

/// The batch of frame `frame`: 20 new landmarks, 3 of the previous frame's updated (seen again),
/// 2 of them removed, one keyframe. Positions follow from the id.
StoreBatch crashBatch(int32_t frame, int32_t session) {
  StoreBatch b;
  const auto landmark = [&](uint64_t id) {
    StoredLandmark l;
    l.id = id;
    l.p_m = {
        std::sin(0.1 * static_cast<double>(id)) * 30.0, std::cos(0.37 * id) * 30.0, id % 7 * 0.5};
    l.session = session;
    l.last_seen_frame = frame;
    l.descriptor.assign(32, static_cast<uint8_t>(id));
    return l;
  };
  for (int i = 0; i < kNewPerFrame; ++i) b.upserts.push_back(landmark(frame * kIdsPerFrame + i));
  if (frame > 0) {
    const uint64_t prev = static_cast<uint64_t>(frame - 1) * kIdsPerFrame;
    for (int i = 0; i < kUpdatedPerFrame; ++i) b.upserts.push_back(landmark(prev + i));
    for (int i = 0; i < kRemovedPerFrame; ++i) b.removed.push_back(prev + kNewPerFrame - 1 - i);
  }
  StoredKeyframe k;
  k.session = session;
  k.frame = frame;
  k.t_ns = frame * 50'000'000LL;
  k.T_m_b.translation() = Eigen::Vector3d(frame * 0.1, 0.0, 0.0);
  b.keyframes.push_back(k);
  return b;
}

/// Child process: continue the store from `first_frame`, reporting each committed frame on `fd`.
/// Only ever leaves through _exit (no atexit handlers, no sanitizer reports from the child).
[[noreturn]] void crashWriter(const std::string& path,
                              const LandmarkStoreOptions& options,
                              int32_t first_frame,
                              int fd) {
  std::unique_ptr<LandmarkStore> store;
  if (!LandmarkStore::open(path, OpenMode::kCreateOrExtend, &store, options).isOk()) _exit(2);
  int32_t session = 0;
  if (!store->beginSession("rig", "config", "crash.rawlog", &session).isOk()) _exit(3);
  for (int32_t frame = first_frame; frame < first_frame + 100000; ++frame) {
    if (!store->writeBatch(crashBatch(frame, session)).isOk()) _exit(4);
    if (write(fd, &frame, sizeof(frame)) != sizeof(frame)) _exit(5);
  }
  _exit(0);
}

/// id -> last_seen_frame after frames 0..last_frame.
std::map<uint64_t, int32_t> expectedAfter(int32_t last_frame) {
  std::map<uint64_t, int32_t> state;
  for (int32_t f = 0; f <= last_frame; ++f) {
    const StoreBatch b = crashBatch(f, 0);
    for (const auto& l : b.upserts) state[l.id] = l.last_seen_frame;
    for (uint64_t id : b.removed) state.erase(id);
  }
  return state;
}

/// 20 writers, each killed with SIGKILL at a seeded moment (after 0-30 reported commits plus
/// 0-3 ms), each continuing the store the previous one left.
void runCrashTrials(const std::string& name, bool sync_every_commit) {
  LandmarkStoreOptions options;
  options.sync_every_commit = sync_every_commit;
  constexpr int kTrials = 20;
  constexpr int kMaxReportsBeforeKill = 30;
  constexpr int kMaxExtraDelayUs = 3000;
  const std::string path = test::makeTempDir(name) + "/map.db";
  std::mt19937 rng(kSeed);
  std::uniform_int_distribution<int> reports_before_kill(0, kMaxReportsBeforeKill);
  std::uniform_int_distribution<int> extra_delay_us(0, kMaxExtraDelayUs);
  int32_t next_frame = 0;
  int killed_in_creation = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const int wait_reports = reports_before_kill(rng);
    const int delay_us = extra_delay_us(rng);
    int fds[2];
    ASSERT_EQ(pipe(fds), 0);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      close(fds[0]);
      crashWriter(path, options, next_frame, fds[1]);
    }
    close(fds[1]);
    std::vector<int32_t> reported;
    const auto read_reports = [&](size_t until) {
      while (reported.size() < until) {
        int32_t frame = 0;
        const ssize_t n = read(fds[0], &frame, sizeof(frame));
        if (n != static_cast<ssize_t>(sizeof(frame))) return false;  // EOF: the child is gone
        reported.push_back(frame);
      }
      return true;
    };
    const bool alive = read_reports(static_cast<size_t>(wait_reports));
    usleep(static_cast<useconds_t>(delay_us));
    kill(pid, SIGKILL);
    int wstatus = 0;
    ASSERT_EQ(waitpid(pid, &wstatus, 0), pid);
    ASSERT_TRUE(alive && WIFSIGNALED(wstatus) && WTERMSIG(wstatus) == SIGKILL)
        << "trial " << trial << ": the writer stopped by itself, exit status "
        << (WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1);
    read_reports(SIZE_MAX);  // whatever it reported before the kill
    close(fds[0]);
    const int32_t last_reported = reported.empty() ? next_frame - 1 : reported.back();

    if (!fs::exists(path)) {
      // Killed while creating the store: nothing can have been committed.
      ASSERT_EQ(last_reported, -1) << "trial " << trial;
      ++killed_in_creation;
      continue;
    }
    // Every other trial the killed writer's log is first met by a reader (as `twocam map info`
    // would), the others by a writer.
    const OpenMode mode = trial % 2 == 0 ? OpenMode::kReadOnly : OpenMode::kCreateOrExtend;
    std::unique_ptr<LandmarkStore> store;
    const Status st = LandmarkStore::open(path, mode, &store);
    ASSERT_TRUE(st.isOk()) << "trial " << trial << ": " << st.message();
    const Status integrity = store->integrityCheck();
    ASSERT_TRUE(integrity.isOk()) << "trial " << trial << ": " << integrity.message();
    StoreInfo info;
    ASSERT_TRUE(store->info(&info).isOk());
    std::vector<int32_t> frames;
    for (const StoredSession& s : info.sessions) {
      std::vector<StoredKeyframe> kf;
      ASSERT_TRUE(store->keyframes(s.id, &kf).isOk());
      for (const auto& k : kf) frames.push_back(k.frame);
    }
    std::sort(frames.begin(), frames.end());
    const int32_t last_stored = frames.empty() ? -1 : frames.back();
    // Every reported commit is there; at most the one in flight beyond it.
    ASSERT_GE(last_stored, last_reported) << "trial " << trial << ": a committed frame was lost";
    EXPECT_LE(last_stored, last_reported + 1) << "trial " << trial;
    for (size_t i = 0; i < frames.size(); ++i) {
      ASSERT_EQ(frames[i], static_cast<int32_t>(i)) << "trial " << trial << ": keyframes missing";
    }
    // The landmarks are exactly those of the stored frames: no half-applied batch.
    const std::map<uint64_t, int32_t> expected = expectedAfter(last_stored);
    std::vector<StoredLandmark> loaded;
    ASSERT_TRUE(store->loadAll(&loaded).isOk());
    ASSERT_EQ(loaded.size(), expected.size()) << "trial " << trial;
    auto it = expected.begin();
    for (const StoredLandmark& l : loaded) {
      ASSERT_EQ(l.id, it->first);
      ASSERT_EQ(l.last_seen_frame, it->second);
      ++it;
    }
    next_frame = last_stored + 1;
  }
  std::cout << "crash trials: " << kTrials << " kills, " << next_frame
            << " frames committed in all, " << killed_in_creation << " kills during creation\n";
  EXPECT_GT(next_frame, kTrials);  // the writers got somewhere
  EXPECT_LT(killed_in_creation, kTrials);
  // A last writer continues on the store in this process.
  auto store = openOrDie(path, OpenMode::kCreateOrExtend);
  ASSERT_TRUE(store);
  const int32_t session = beginOrDie(*store);
  ASSERT_TRUE(store->writeBatch(crashBatch(next_frame, session)).isOk());
  EXPECT_TRUE(store->integrityCheck().isOk());
}

TEST(LandmarkStoreCrash, SurvivesSigkillAtTwentySeededMomentsSynchronousFull) {
  runCrashTrials("store_crash_full", true);
}

TEST(LandmarkStoreCrash, SurvivesSigkillAtTwentySeededMomentsSynchronousNormal) {
  runCrashTrials("store_crash_normal", false);
}

TEST(LandmarkStoreCrash, AWriterKilledWhileCreatingLeavesNoStoreOrAWholeOne) {
  constexpr int kTrials = 12;
  constexpr int kMaxDelayUs = 4000;  // creating a store takes a few ms here
  const std::string dir = test::makeTempDir("store_crash_create");
  std::mt19937 rng(kSeed);
  std::uniform_int_distribution<int> delay_us(0, kMaxDelayUs);
  int whole = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const std::string path = dir + "/map" + std::to_string(trial) + ".db";
    const int delay = delay_us(rng);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      std::unique_ptr<LandmarkStore> store;
      _exit(LandmarkStore::open(path, OpenMode::kCreateOrExtend, &store).isOk() ? 0 : 2);
    }
    usleep(static_cast<useconds_t>(delay));
    kill(pid, SIGKILL);
    int wstatus = 0;
    ASSERT_EQ(waitpid(pid, &wstatus, 0), pid);
    ASSERT_FALSE(WIFEXITED(wstatus) && WEXITSTATUS(wstatus) != 0) << "trial " << trial;
    if (!fs::exists(path)) continue;  // killed before the rename: no store, and no error later
    std::unique_ptr<LandmarkStore> store;
    const Status st = LandmarkStore::open(path, OpenMode::kReadOnly, &store);
    ASSERT_TRUE(st.isOk()) << "trial " << trial << " (killed after " << delay
                           << " us): " << st.message();
    EXPECT_TRUE(store->integrityCheck().isOk());
    ++whole;
  }
  std::cout << "creation kills: " << kTrials << ", stores found whole: " << whole << "\n";
}

}  // namespace
}  // namespace twocam::store
