/// The mapping stage (mapping/occupancy_mapper.h) against OctoMap's own scan insertion, in one
/// binary, on the same frames: OccupancyMapper::insertFrame versus
/// octomap::OcTree::insertPointCloud(cloud, origin, max_range, lazy_eval = false,
/// discretize = true), which casts the same rays (one per distinct end voxel, free space up to
/// it) through OctoMap's KeySets and per-key updateNode.
///
/// Two frame sources, both built outside the timed loop:
///  - office: per frame the camera origin and the mapped landmarks of a pipeline run (default
///    config) over the log in TWOCAM_BENCH_LOG (default out/office.rawlog); skipped with a
///    message when the log is absent.
///  - synthetic: a seeded camera walking a 10 x 8 m room, about 800 wall points 1-6 m away.
///
/// Each iteration inserts the whole sequence into a fresh map (the map's state, e.g. clamped
/// and pruned free space, shapes the cost as it does in a run); per_frame is the time per frame.
///
///   TWOCAM_BENCH_LOG=/tmp/cb/office.rawlog taskset -c 1 build/tests/bench/mapping_bench
///
/// The two models do not build the same tree: OctoMap's discretised insertion casts each ray to
/// the end voxel's centre, ours to the first landmark in the voxel; the work is the same.

#include <benchmark/benchmark.h>
#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "io/rawlog.h"
#include "mapping/occupancy_mapper.h"
#include "mapping/options.h"
#include "pipeline/config.h"
#include "pipeline/pipeline.h"

namespace twocam::bench {
namespace {

constexpr uint64_t kMappingBenchSeed = 20261207;

struct MapFrame {
  Eigen::Vector3d origin_w;
  std::vector<Eigen::Vector3d> points_w;
};

struct FrameSequence {
  std::string error;  ///< non-empty: the source is unavailable (message for SkipWithError)
  std::vector<MapFrame> frames;
};

/// The frames the pipeline maps on the recorded log (camera origin and mapped landmarks).
const FrameSequence& officeFrames() {
  static const FrameSequence kFrames = [] {
    FrameSequence s;
    const char* env = std::getenv("TWOCAM_BENCH_LOG");
    const std::string path = env ? env : "out/office.rawlog";
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      s.error = path + " not found: set TWOCAM_BENCH_LOG to a rawlog with odometry";
      return s;
    }
    std::unique_ptr<io::RawlogReader> reader;
    if (Status st = io::RawlogReader::open(path, &reader); !st) {
      s.error = st.message();
      return s;
    }
    pipeline::PipelineConfig config;
    if (Status st = pipeline::clampToRig(reader->rig(), &config); !st) {
      s.error = st.message();
      return s;
    }
    pipeline::Pipeline pipe(reader->rig(), config);
    pipeline::FrameOutput out;
    io::LogFrame f;
    Status st;
    while (reader->next(&f, &st)) {
      if (!f.odometry) continue;
      if (!pipe.process(f.index, f.stereo, f.odometry->pose, &out) || out.outside_map) continue;
      s.frames.push_back({out.camera_origin_w, out.mapped_points_w});
    }
    if (!st) s.error = st.message();
    if (s.frames.empty() && s.error.empty()) s.error = path + ": no mapped frames";
    return s;
  }();
  return kFrames;
}

/// A camera at 0.3 m height walking an ellipse in a 10 x 8 x 2.5 m room (walls at x = +-5,
/// y = +-4, floor and ceiling), looking along its path with a 90 degree field of view; each
/// frame sees about 800 points on the surfaces 1-6 m away, with 1 cm noise.
const FrameSequence& syntheticFrames() {
  static const FrameSequence kFrames = [] {
    constexpr int kFrameCount = 200;
    constexpr int kPointsPerFrame = 800;
    constexpr double kHalfX = 5.0, kHalfY = 4.0, kHeight = 2.5;
    FrameSequence s;
    std::mt19937 rng(kMappingBenchSeed);
    std::uniform_real_distribution<double> angle(-M_PI / 4.0, M_PI / 4.0);
    std::uniform_real_distribution<double> elevation(-0.5, 0.5);
    std::normal_distribution<double> noise(0.0, 0.01);
    for (int i = 0; i < kFrameCount; ++i) {
      const double t = 2.0 * M_PI * i / kFrameCount;
      MapFrame f;
      f.origin_w = Eigen::Vector3d(2.5 * std::cos(t), 2.0 * std::sin(t), 0.3);
      const double heading = std::atan2(2.0 * std::cos(t), -2.5 * std::sin(t));
      while (static_cast<int>(f.points_w.size()) < kPointsPerFrame) {
        const double a = heading + angle(rng);
        const Eigen::Vector3d d =
            Eigen::Vector3d(std::cos(a), std::sin(a), elevation(rng)).normalized();
        // Distance to the first surface the direction meets (the room is convex).
        double range = 1e9;
        for (int k = 0; k < 3; ++k) {
          if (d[k] == 0.0) continue;
          const double lo = k == 0 ? -kHalfX : k == 1 ? -kHalfY : 0.0;
          const double hi = k == 0 ? kHalfX : k == 1 ? kHalfY : kHeight;
          range = std::min(range, ((d[k] > 0.0 ? hi : lo) - f.origin_w[k]) / d[k]);
        }
        if (range < 1.0 || range > 6.0) continue;
        f.points_w.push_back(f.origin_w + (range + noise(rng)) * d);
      }
      s.frames.push_back(std::move(f));
    }
    return s;
  }();
  return kFrames;
}

const FrameSequence& frames(bool office) { return office ? officeFrames() : syntheticFrames(); }

/// TwoCam's batched update.
struct Ours {
  explicit Ours(const FrameSequence& /*seq*/) {}
  static std::unique_ptr<mapping::OccupancyMapper> makeMap() {
    return std::make_unique<mapping::OccupancyMapper>(mapping::MappingOptions{});
  }
  void insert(mapping::OccupancyMapper* map, size_t i, const FrameSequence& seq) const {
    map->insertFrame(seq.frames[i].origin_w, seq.frames[i].points_w);
  }
};

/// OctoMap's insertPointCloud with the same sensor model options; the clouds are converted to
/// OctoMap's float points outside the timed loop.
struct OctoMap {
  explicit OctoMap(const FrameSequence& seq) {
    for (const MapFrame& f : seq.frames) {
      octomap::Pointcloud cloud;
      cloud.reserve(f.points_w.size());
      for (const Eigen::Vector3d& p : f.points_w) {
        cloud.push_back(
            static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
      }
      clouds.push_back(std::move(cloud));
      origins.emplace_back(static_cast<float>(f.origin_w.x()),
                           static_cast<float>(f.origin_w.y()),
                           static_cast<float>(f.origin_w.z()));
    }
  }
  static std::unique_ptr<octomap::OcTree> makeMap() {
    const mapping::MappingOptions o;
    auto tree = std::make_unique<octomap::OcTree>(o.resolution_m);
    tree->setProbHit(o.prob_hit);
    tree->setProbMiss(o.prob_miss);
    tree->setClampingThresMin(o.clamp_min);
    tree->setClampingThresMax(o.clamp_max);
    tree->setOccupancyThres(o.occupied_threshold);
    return tree;
  }
  void insert(octomap::OcTree* tree, size_t i, const FrameSequence& /*seq*/) const {
    tree->insertPointCloud(
        clouds[i], origins[i], mapping::MappingOptions{}.max_range_m, false, true);
  }
  std::vector<octomap::Pointcloud> clouds;
  std::vector<octomap::point3d> origins;
};

/// Times Model's insertion of the whole sequence into a fresh map per iteration.
template <class Model>
void timeInsertions(benchmark::State& state, bool office) {
  const FrameSequence& seq = frames(office);
  if (!seq.error.empty()) {
    state.SkipWithError(seq.error.c_str());
    return;
  }
  const Model model(seq);
  int64_t points = 0;
  for (const MapFrame& f : seq.frames) points += static_cast<int64_t>(f.points_w.size());
  for (auto _ : state) {
    auto map = Model::makeMap();
    for (size_t i = 0; i < seq.frames.size(); ++i) model.insert(map.get(), i, seq);
    benchmark::DoNotOptimize(map.get());
    state.PauseTiming();  // freeing a large tree is not insertion
    map.reset();
    state.ResumeTiming();
  }
  const auto n = static_cast<double>(seq.frames.size());
  state.counters["frames"] = n;
  state.counters["points_per_frame"] = static_cast<double>(points) / n;
  state.counters["per_frame"] = benchmark::Counter(
      n, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// OccupancyMapper::insertFrame.
void BM_InsertFrame(benchmark::State& state, bool office) { timeInsertions<Ours>(state, office); }
/// octomap::OcTree::insertPointCloud(discretize = true).
void BM_OctomapInsertPointCloud(benchmark::State& state, bool office) {
  timeInsertions<OctoMap>(state, office);
}

BENCHMARK_CAPTURE(BM_InsertFrame, office, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_OctomapInsertPointCloud, office, true)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_InsertFrame, synthetic, false)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_OctomapInsertPointCloud, synthetic, false)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace twocam::bench
