/// Landmark database update (landmarks/landmark_database.h) on the seeded synthetic hypothesis
/// stream of tests/support/synthetic_stream.h, against the speed target of the landmark issue:
/// "landmark update within 1 ms median per frame with 1,000 hypotheses per frame and 10,000 live
/// candidates; memory flat over a 5,000-frame run".
///
/// Run on one core: taskset -c 0 landmarks_bench --benchmark_repetitions=5
/// --benchmark_report_aggregates_only=true. Stream generation is never timed (manual timing
/// around update() only); every repetition replays the same seeded frames.
///
/// Two loads, same stream:
///  - target_load: default LandmarkOptions except that candidates are kept while out of view
///    (max_frames_out_of_view very large). With the defaults a candidate dies 5 frames after it
///    leaves the view, so 1,000 hypotheses per frame sustain only 1,000-1,400 live candidates;
///    keeping them lets the database reach the target's 10,000 (they are still predicted every
///    frame, which is what the target is about). Since evidence is counted every frame
///    (evidence_step_m 0.01, 2026-12-02) doubtful candidates reach prune_prob sooner and the
///    population fell to 9,200; prune_prob 0.005 instead of 0.02 restores about 10,200.
///  - default_options: LandmarkOptions as shipped, for comparison.

#include <benchmark/benchmark.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "landmarks/landmark_database.h"
#include "landmarks/options.h"
#include "support/synthetic_stream.h"

namespace twocam::bench {
namespace {

using landmarks::FrameReport;
using landmarks::Landmark;
using landmarks::LandmarkDatabase;
using landmarks::LandmarkOptions;
using landmarks::Observation;
using test::SyntheticFrame;
using test::SyntheticStream;
using test::SyntheticStreamOptions;

constexpr uint64_t kLandmarkBenchSeed = 20261129;
/// Frames run before timing starts: target_load then holds 9,700-10,700 live candidates over the
/// timed frames 600-999 (one lap of the circle is 471 frames; later, confirmations and
/// contradictions change the population little: 10,600 at frame 5,000).
constexpr int kWarmupFrames = 600;
/// Frames timed per repetition (one frame per benchmark iteration).
constexpr int kTimedFrames = 400;
/// The memory run and the frames at which it records the database size and the process RSS.
constexpr int kLongRunFrames = 5000;
constexpr int kCheckpoints[] = {500, 1000, 2000, 3000, 4000, 5000};

enum class Load { kTarget, kDefaults };

/// About 1,000 hypotheses per frame, evenly over the lap: a square room (so the view always holds
/// a similar number of wall points), 8,000 points, half of them detected per frame, many rivals.
SyntheticStreamOptions benchStreamOptions() {
  SyntheticStreamOptions so;
  so.num_points = 8000;
  so.half_x_m = 4.0;
  so.half_y_m = 4.0;
  so.detection_prob = 0.5;
  so.random_rival_prob = 0.6;
  so.seed = kLandmarkBenchSeed;
  return so;
}

LandmarkOptions benchLandmarkOptions(Load load) {
  LandmarkOptions options;
  if (load == Load::kTarget) {
    options.tracker.max_frames_out_of_view = 1'000'000;
    options.consistency.prune_prob = 0.005;
  }
  return options;
}

/// Resident set size of this process [MB] (/proc/self/statm, second field, in pages).
double residentMegabytes() {
  std::ifstream statm("/proc/self/statm");
  long size_pages = 0;
  long resident_pages = 0;
  if (!(statm >> size_pages >> resident_pages)) return -1.0;
  return static_cast<double>(resident_pages) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1e6;
}

/// Heap held by the database's landmark slots and their observation buffers [MB] (capacities, so
/// a pool that is reused rather than grown stays flat).
double databaseMegabytes(const LandmarkDatabase& db) {
  const std::vector<Landmark>& slots = db.landmarks();
  size_t bytes = slots.capacity() * sizeof(Landmark);
  for (const Landmark& l : slots) bytes += l.observations.capacity() * sizeof(Observation);
  return static_cast<double>(bytes) / 1e6;
}

/// This thread's CPU time [s]: on a loaded machine it excludes time the core spent elsewhere.
double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct UpdateTime {
  double wall_s = 0.0;
  double cpu_s = 0.0;
};

/// One update, timed (wall clock and thread CPU time); aborts the benchmark on an error status.
UpdateTime timedUpdate(LandmarkDatabase* db,
                       const SyntheticFrame& frame,
                       FrameReport* report,
                       benchmark::State& state) {
  const double cpu0 = threadCpuSeconds();
  const auto t0 = std::chrono::steady_clock::now();
  const Status s = db->update(frame.frame, frame.t_ns, frame.odom_pose, frame.hypotheses, report);
  const auto t1 = std::chrono::steady_clock::now();
  const double cpu1 = threadCpuSeconds();
  benchmark::DoNotOptimize(s);
  if (!s.isOk()) state.SkipWithError(s.message().c_str());
  return {std::chrono::duration<double>(t1 - t0).count(), cpu1 - cpu0};
}

double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const size_t k = static_cast<size_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

/// Per iteration: one update() on the next frame of the stream, after kWarmupFrames untimed
/// frames. Reported time is the mean per frame; frame_*_ms are quantiles over the timed frames
/// (wall clock) and cpu_median_ms the median of this thread's CPU time per frame;
/// hyps, candidates and confirmed are means over the timed frames of the input size and of the
/// database's live counts when update() was called.
void BM_LandmarkUpdate(benchmark::State& state, Load load) {
  const StereoRig rig = SyntheticStream::defaultRig();
  SyntheticStream stream(rig, benchStreamOptions());
  LandmarkDatabase db(rig, benchLandmarkOptions(load));
  SyntheticFrame frame;
  FrameReport report;
  for (int k = 0; k < kWarmupFrames; ++k) {
    stream.next(&frame);
    const Status s = db.update(frame.frame, frame.t_ns, frame.odom_pose, frame.hypotheses, &report);
    if (!s.isOk()) {
      state.SkipWithError(s.message().c_str());
      return;
    }
  }
  std::vector<double> frame_s;
  std::vector<double> frame_cpu_s;
  frame_s.reserve(static_cast<size_t>(state.max_iterations));
  frame_cpu_s.reserve(static_cast<size_t>(state.max_iterations));
  double hyps = 0.0;
  double candidates = 0.0;
  double confirmed = 0.0;
  int min_candidates = db.numCandidates();
  for (auto _ : state) {
    stream.next(&frame);
    hyps += static_cast<double>(frame.hypotheses.hypotheses.size());
    candidates += db.numCandidates();
    confirmed += db.numConfirmed();
    min_candidates = std::min(min_candidates, db.numCandidates());
    const UpdateTime dt = timedUpdate(&db, frame, &report, state);
    state.SetIterationTime(dt.wall_s);
    frame_s.push_back(dt.wall_s);
    frame_cpu_s.push_back(dt.cpu_s);
  }
  const double n = static_cast<double>(frame_s.size());
  state.counters["hyps"] = hyps / n;
  state.counters["candidates"] = candidates / n;
  state.counters["cand_min"] = min_candidates;
  state.counters["confirmed"] = confirmed / n;
  state.counters["frame_median_ms"] = 1e3 * quantile(frame_s, 0.5);
  state.counters["frame_p90_ms"] = 1e3 * quantile(frame_s, 0.9);
  state.counters["frame_max_ms"] = 1e3 * quantile(frame_s, 1.0);
  state.counters["cpu_median_ms"] = 1e3 * quantile(frame_cpu_s, 0.5);
}
BENCHMARK_CAPTURE(BM_LandmarkUpdate, target_load, Load::kTarget)
    ->Iterations(kTimedFrames)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_LandmarkUpdate, default_options, Load::kDefaults)
    ->Iterations(kTimedFrames)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

/// kLongRunFrames frames from a fresh database, once. Prints the live counts, slot count, the
/// database's heap (slots and observation buffers) and the process RSS at kCheckpoints, with the
/// mean and median update time since the previous checkpoint. Reported time is the total update
/// time of the run (manual timing; stream generation excluded).
void BM_LandmarkLongRun(benchmark::State& state, Load load) {
  const char* name = load == Load::kTarget ? "target_load" : "default_options";
  for (auto _ : state) {
    const StereoRig rig = SyntheticStream::defaultRig();
    SyntheticStream stream(rig, benchStreamOptions());
    LandmarkDatabase db(rig, benchLandmarkOptions(load));
    SyntheticFrame frame;
    FrameReport report;
    std::printf("\nBM_LandmarkLongRun/%s\n", name);
    std::printf("%6s %6s %10s %9s %7s %7s %7s %10s %12s\n",
                "frame",
                "hyps",
                "candidates",
                "confirmed",
                "slots",
                "db_MB",
                "rss_MB",
                "mean_ms",
                "median_ms");
    double total_s = 0.0;
    double segment_hyps = 0.0;
    std::vector<double> segment_s;
    size_t next_checkpoint = 0;
    for (int k = 1; k <= kLongRunFrames; ++k) {
      stream.next(&frame);
      segment_hyps += static_cast<double>(frame.hypotheses.hypotheses.size());
      const double dt = timedUpdate(&db, frame, &report, state).wall_s;
      total_s += dt;
      segment_s.push_back(dt);
      if (next_checkpoint < std::size(kCheckpoints) && k == kCheckpoints[next_checkpoint]) {
        const double rss_mb = residentMegabytes();
        const double db_mb = databaseMegabytes(db);
        const double n = static_cast<double>(segment_s.size());
        double sum_s = 0.0;
        for (double s : segment_s) sum_s += s;
        std::printf("%6d %6.0f %10d %9d %7zu %7.1f %7.1f %10.3f %12.3f\n",
                    k,
                    segment_hyps / n,
                    db.numCandidates(),
                    db.numConfirmed(),
                    db.landmarks().size(),
                    db_mb,
                    rss_mb,
                    1e3 * sum_s / n,
                    1e3 * quantile(segment_s, 0.5));
        const std::string at = std::to_string(k);
        if (k == kCheckpoints[0] || k == kLongRunFrames) {
          state.counters["rss_MB@" + at] = rss_mb;
          state.counters["db_MB@" + at] = db_mb;
          state.counters["cand@" + at] = db.numCandidates();
          state.counters["conf@" + at] = db.numConfirmed();
        }
        segment_s.clear();
        segment_hyps = 0.0;
        ++next_checkpoint;
      }
    }
    std::fflush(stdout);
    state.SetIterationTime(total_s);
  }
}
BENCHMARK_CAPTURE(BM_LandmarkLongRun, target_load, Load::kTarget)
    ->Iterations(1)
    ->Repetitions(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);
BENCHMARK_CAPTURE(BM_LandmarkLongRun, default_options, Load::kDefaults)
    ->Iterations(1)
    ->Repetitions(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace twocam::bench
