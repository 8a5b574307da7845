/// The landmark store (store/landmark_store.h) against the questions of issue 25: what one
/// transaction per frame costs against one per 10 frames (and synchronous=NORMAL against FULL),
/// and how fast the R*Tree answers a working-set query (r = 6 m) in a map of 100,000 landmarks.
///
/// Run on one core: taskset -c 1 store_bench --benchmark_repetitions=5
/// --benchmark_report_aggregates_only=true. The stores live in a folder under
/// $TMPDIR (or /tmp), removed at the end; on this machine /tmp is on the same disk as /work.
///
/// A frame's batch: one keyframe, 60 upserted landmarks with 32-byte descriptors (50 new, 10 of
/// the previous frame seen again) and 5 removals, scattered over the map with every upsert
/// moving (worst case) or near the robot with the seen-again landmarks unmoved (FrameStream).
/// Batches are built outside the timed region (manual timing around writeBatch() only);
/// items_per_second counts frames.

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "store/landmark_store.h"

namespace twocam::bench {
namespace {

namespace fs = std::filesystem;
using store::LandmarkStore;
using store::OpenMode;
using store::StoreBatch;
using store::StoredKeyframe;
using store::StoredLandmark;

constexpr uint64_t kStoreBenchSeed = 20261203;
constexpr int kNewPerFrame = 50;
constexpr int kSeenAgainPerFrame = 10;
constexpr int kRemovedPerFrame = 5;
constexpr size_t kDescriptorBytes = 32;
/// The query map: 100,000 landmarks uniform in 200 m x 200 m x 3 m (about 280 within 6 m).
constexpr int kQueryMapLandmarks = 100000;
constexpr double kQueryMapHalfWidthM = 100.0;
constexpr double kQueryMapHeightM = 3.0;
constexpr double kQueryRadiusM = 6.0;

std::string benchDir() {
  const fs::path dir =
      fs::temp_directory_path() / ("twocam_store_bench_" + std::to_string(getpid()));
  fs::create_directories(dir);
  return dir.string();
}

StoredLandmark makeLandmark(std::mt19937_64& rng, uint64_t id, int32_t session, int32_t frame) {
  std::uniform_real_distribution<double> xy(-kQueryMapHalfWidthM, kQueryMapHalfWidthM),
      z(0.0, kQueryMapHeightM);
  std::uniform_int_distribution<int> byte(0, 255);
  StoredLandmark l;
  l.id = id;
  l.p_m = {xy(rng), xy(rng), z(rng)};
  l.cov_m = Eigen::Matrix3d::Identity() * 1e-4;
  l.confidence = 0.9;
  l.observations = 5;
  l.session = session;
  l.first_seen_frame = frame;
  l.last_seen_frame = frame;
  l.first_seen_t_ns = frame * 50'000'000LL;
  l.last_seen_t_ns = l.first_seen_t_ns;
  l.descriptor_kind = 1;
  l.descriptor.resize(kDescriptorBytes);
  for (uint8_t& b : l.descriptor) b = static_cast<uint8_t>(byte(rng));
  return l;
}

/// Where a frame's landmarks lie: kScattered draws them uniformly over the whole 200 m x 200 m
/// map (the worst case for the R*Tree: every insert in another leaf); kLocal draws them within
/// kLocalHalfWidthM of a robot driving a circle of radius kPathRadiusM at kStepM per frame, as a
/// camera sees them.
enum class Layout { kScattered, kLocal };
constexpr double kLocalHalfWidthM = 8.0;
constexpr double kPathRadiusM = 80.0;
constexpr double kStepM = 0.05;

/// The frames' batches (ids frame * 64 + i). With moved = false a landmark seen again keeps its
/// position, as the tracker keeps a confirmed landmark's (it is not re-refined); moved = true
/// draws a new one (the worst case: every upsert moves an R*Tree entry).
class FrameStream {
 public:
  FrameStream(Layout layout, bool moved, int32_t session)
      : layout_(layout), moved_(moved), session_(session), rng_(kStoreBenchSeed) {}

  void append(int32_t frame, StoreBatch* batch) {
    const double angle = frame * kStepM / kPathRadiusM;
    const Eigen::Vector3d robot(
        kPathRadiusM * std::cos(angle), kPathRadiusM * std::sin(angle), 0.0);
    std::uniform_real_distribution<double> near(-kLocalHalfWidthM, kLocalHalfWidthM);
    const auto add = [&](uint64_t id) {
      StoredLandmark l = makeLandmark(rng_, id, session_, frame);
      if (layout_ == Layout::kLocal) {
        l.p_m.x() = robot.x() + near(rng_);
        l.p_m.y() = robot.y() + near(rng_);
      }
      batch->upserts.push_back(std::move(l));
    };
    const uint64_t base = static_cast<uint64_t>(frame) * 64;
    if (frame > 0) {
      const uint64_t prev = base - 64;
      for (int i = 0; i < kSeenAgainPerFrame; ++i) {
        add(prev + i);
        if (!moved_) batch->upserts.back().p_m = previous_[static_cast<size_t>(i)];
      }
      for (int i = 0; i < kRemovedPerFrame; ++i) {
        batch->removed.push_back(prev + kNewPerFrame - 1 - i);
      }
    }
    previous_.clear();
    for (int i = 0; i < kNewPerFrame; ++i) {
      add(base + i);
      if (i < kSeenAgainPerFrame) previous_.push_back(batch->upserts.back().p_m);
    }
    StoredKeyframe k;
    k.session = session_;
    k.frame = frame;
    k.t_ns = frame * 50'000'000LL;
    k.T_m_b.translation() = robot;
    batch->keyframes.push_back(k);
  }

 private:
  Layout layout_;
  bool moved_;
  int32_t session_;
  std::mt19937_64 rng_;
  std::vector<Eigen::Vector3d> previous_;
};

/// Args: frames per transaction, synchronous FULL (1) or NORMAL (0), local layout (1) or
/// scattered (0), landmarks seen again moved (1) or not (0).
void BM_WriteFrames(benchmark::State& state) {
  const int frames_per_transaction = static_cast<int>(state.range(0));
  store::LandmarkStoreOptions options;
  options.sync_every_commit = state.range(1) != 0;
  const Layout layout = state.range(2) != 0 ? Layout::kLocal : Layout::kScattered;
  const bool moved = state.range(3) != 0;
  const std::string dir = benchDir();
  const std::string path = dir + "/write.db";
  fs::remove(path);
  std::unique_ptr<LandmarkStore> map;
  if (!LandmarkStore::open(path, OpenMode::kCreateOrExtend, &map, options).isOk()) {
    state.SkipWithError("cannot create the store");
    return;
  }
  int32_t session = 0;
  if (!map->beginSession("rig", "config", "bench", &session).isOk()) {
    state.SkipWithError("cannot begin a session");
    return;
  }
  FrameStream stream(layout, moved, session);
  int32_t frame = 0;
  for (auto _ : state) {
    StoreBatch batch;
    for (int i = 0; i < frames_per_transaction; ++i) stream.append(frame++, &batch);
    const auto start = std::chrono::steady_clock::now();
    const Status st = map->writeBatch(batch);
    const auto stop = std::chrono::steady_clock::now();
    if (!st) {
      state.SkipWithError(st.message().c_str());
      break;
    }
    state.SetIterationTime(std::chrono::duration<double>(stop - start).count());
  }
  state.SetItemsProcessed(static_cast<int64_t>(frame));
  state.counters["frames_per_txn"] = frames_per_transaction;
  map.reset();
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(path + suffix);
}
BENCHMARK(BM_WriteFrames)
    ->ArgNames({"frames_per_txn", "sync_full", "local", "moved"})
    // Worst case: scattered over the map, the seen-again landmarks moved.
    ->ArgsProduct({{1, 10}, {0, 1}, {0}, {1}})
    // As a camera sees them: near the robot, the seen-again landmarks where they were.
    ->ArgsProduct({{1, 10}, {0, 1}, {1}, {0}})
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

/// The 100,000-landmark map, built once per process.
const std::string& queryMap() {
  static const std::string kPath = [] {
    const std::string p = benchDir() + "/query.db";
    fs::remove(p);
    std::unique_ptr<LandmarkStore> map;
    if (!LandmarkStore::open(p, OpenMode::kCreateOrExtend, &map).isOk()) return std::string();
    int32_t session = 0;
    if (!map->beginSession("rig", "config", "bench", &session).isOk()) return std::string();
    std::mt19937_64 rng(kStoreBenchSeed + 1);
    StoreBatch batch;
    for (int i = 0; i < kQueryMapLandmarks; ++i) {
      batch.upserts.push_back(makeLandmark(rng, 1 + i, session, i / 50));
    }
    if (!map->writeBatch(batch).isOk()) return std::string();
    return p;
  }();
  return kPath;
}

void BM_QueryRadius(benchmark::State& state) {
  const std::string& path = queryMap();
  std::unique_ptr<LandmarkStore> map;
  if (path.empty() || !LandmarkStore::open(path, OpenMode::kReadOnly, &map).isOk()) {
    state.SkipWithError("no query map");
    return;
  }
  std::mt19937_64 rng(kStoreBenchSeed + 2);
  std::uniform_real_distribution<double> xy(-kQueryMapHalfWidthM, kQueryMapHalfWidthM);
  std::vector<Eigen::Vector3d> centers(1024);
  for (auto& c : centers) c = {xy(rng), xy(rng), kQueryMapHeightM / 2};
  std::vector<StoredLandmark> found;
  size_t i = 0, total = 0;
  for (auto _ : state) {
    if (!map->queryRadius(centers[i++ % centers.size()], kQueryRadiusM, &found).isOk()) {
      state.SkipWithError("query failed");
      break;
    }
    total += found.size();
    benchmark::DoNotOptimize(found.data());
  }
  state.counters["landmarks_found"] =
      benchmark::Counter(static_cast<double>(total), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_QueryRadius)->Unit(benchmark::kMicrosecond);

/// Opening the 100,000-landmark map read-only (header checks + PRAGMA quick_check) and loading
/// every landmark: the "load" part of the "open and relocalise within 1 s".
void BM_OpenAndLoadAll(benchmark::State& state) {
  const std::string& path = queryMap();
  const bool load = state.range(0) != 0;
  std::vector<StoredLandmark> all;
  for (auto _ : state) {
    std::unique_ptr<LandmarkStore> map;
    if (path.empty() || !LandmarkStore::open(path, OpenMode::kReadOnly, &map).isOk()) {
      state.SkipWithError("cannot open the query map");
      break;
    }
    if (load && !map->loadAll(&all).isOk()) {
      state.SkipWithError("loadAll failed");
      break;
    }
    benchmark::DoNotOptimize(all.data());
  }
  state.counters["landmarks"] = static_cast<double>(all.size());
}
BENCHMARK(BM_OpenAndLoadAll)->ArgName("load_all")->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace twocam::bench

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  // The stores of this process.
  std::error_code ec;
  std::filesystem::remove_all(
      std::filesystem::temp_directory_path() / ("twocam_store_bench_" + std::to_string(getpid())),
      ec);
  return 0;
}
