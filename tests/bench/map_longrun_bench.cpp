/// The long-run goals of the landmark store and of localisation: a world's path driven for many
/// laps (default office_loops, 10 000 frames), rendered frame by frame in memory (no log on disk)
/// and run through the pipeline (fused localisation) into a map file (`twocam run --map`), once
/// with every landmark in the tracker and once with a bounded working set
/// (pipeline/working_set.h). Per lap it records the process RSS, the tracker's landmarks, the
/// map's rows and file size, the working set's paging, the frame and paging times and the pose
/// error against the simulator's truth; the benchmark's counters summarise them.
///
///   build/release/tests/bench/map_longrun_bench                      # 10 000 frames
///   TWOCAM_LONGRUN_FRAMES=100000 TWOCAM_LONGRUN_CSV=/tmp/longrun
///     build/release/tests/bench/map_longrun_bench --benchmark_filter=working_set
/// (one line; run each benchmark in its own process: RSS is the process's, and freed memory
/// stays with the allocator).
///
/// Settings (environment): TWOCAM_LONGRUN_WORLD (world file), TWOCAM_LONGRUN_FRAMES,
/// TWOCAM_LONGRUN_RADIUS (working-set radius [m], default 3: office's rooms are 3 m across),
/// TWOCAM_LONGRUN_MAX (working-set cap, default 0 = none), TWOCAM_LONGRUN_CSV (prefix: writes
/// PREFIX_<benchmark>.csv, one row per lap), TWOCAM_LONGRUN_DIR (where the map file goes,
/// default the system's temporary folder; removed afterwards).
///
/// The run keeps no per-frame records (RunOptions::keep_frame_records false) and nothing of the
/// evaluation: what grows is the pipeline's and the map's own state.

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "common/timer.h"
#include "pipeline/config.h"
#include "pipeline/map_session.h"
#include "pipeline/run.h"
#include "sim/simulator.h"
#include "sim/world_io.h"

#ifndef TWOCAM_SOURCE_DIR
#define TWOCAM_SOURCE_DIR "."
#endif

namespace twocam {
namespace {

namespace fs = std::filesystem;

std::string envOr(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::string(v) : fallback;
}

/// Resident set size of this process [MB] (/proc/self/statm, second field, in pages).
double residentMegabytes() {
  std::ifstream statm("/proc/self/statm");
  long size_pages = 0;
  long resident_pages = 0;
  if (!(statm >> size_pages >> resident_pages)) return -1.0;
  return static_cast<double>(resident_pages) * static_cast<double>(sysconf(_SC_PAGESIZE)) / 1e6;
}

double fileMegabytes(const std::string& path) {
  std::error_code ec;
  double bytes = 0.0;
  for (const char* suffix : {"", "-wal"}) {
    const auto n = fs::file_size(path + suffix, ec);
    if (!ec) bytes += static_cast<double>(n);
  }
  return bytes / 1e6;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

/// One row per lap (the robot back within kLapRadiusM of its start after having left it by more
/// than kLeaveRadiusM).
struct LapRow {
  int lap = 0;
  int end_frame = 0;
  double rss_mb = 0.0;
  int tracker_confirmed = 0;
  int tracker_candidates = 0;
  int64_t map_landmarks = 0;
  double map_file_mb = 0.0;
  int64_t paged_out = 0;  ///< cumulative
  int64_t paged_in = 0;   ///< cumulative
  int confirmations = 0;  ///< in this lap
  int reassociated = 0;   ///< in this lap
  double frame_ms_mean = 0.0;
  double paging_ms_mean = 0.0;  ///< working-set checks in this lap, per frame
  double pos_rmse_m = 0.0;      ///< fused position error in this lap (odometry starts at the truth)
  double odom_rmse_m = 0.0;
};

constexpr double kLapRadiusM = 0.5;
constexpr double kLeaveRadiusM = 2.0;

void BM_MapLongRun(benchmark::State& state, bool working_set) {
  const std::string world_path =
      envOr("TWOCAM_LONGRUN_WORLD", std::string(TWOCAM_SOURCE_DIR) + "/worlds/office_loops.yaml");
  const int frames = std::stoi(envOr("TWOCAM_LONGRUN_FRAMES", "10000"));
  const double radius_m = std::stod(envOr("TWOCAM_LONGRUN_RADIUS", "3"));
  const int cap = std::stoi(envOr("TWOCAM_LONGRUN_MAX", "0"));
  const std::string csv_prefix = envOr("TWOCAM_LONGRUN_CSV", "");
  const std::string dir = envOr("TWOCAM_LONGRUN_DIR", fs::temp_directory_path().string());

  sim::World world;
  if (Status s = sim::loadWorld(world_path, &world); !s) {
    state.SkipWithError(("TWOCAM_LONGRUN_WORLD: " + s.message()).c_str());
    return;
  }
  world.frames = frames;
  if (!world.robot.loop) {
    state.SkipWithError((world_path + ": the path does not loop; a long run needs one").c_str());
    return;
  }

  for (auto _ : state) {
    std::unique_ptr<sim::Simulator> simulator;
    if (Status s = sim::Simulator::create(world, sim::RendererOptions{}, &simulator); !s) {
      state.SkipWithError(s.message().c_str());
      return;
    }
    pipeline::PipelineConfig config;
    if (Status s = pipeline::clampToRig(world.rig, &config); !s) {
      state.SkipWithError(s.message().c_str());
      return;
    }
    const std::string map_path =
        (fs::path(dir) / ("twocam_longrun_" + std::to_string(getpid()) + ".db")).string();
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(map_path + suffix);
    pipeline::MapSessionOptions mopt;
    if (working_set) {
      mopt.working_set.radius_m = radius_m;
      mopt.working_set.max_landmarks = cap;
    }
    std::unique_ptr<pipeline::MapSession> session;
    if (Status s =
            pipeline::MapSession::open(map_path, world.rig, config, world_path, mopt, &session);
        !s) {
      state.SkipWithError(s.message().c_str());
      return;
    }

    pipeline::RunOptions ropt;
    ropt.keep_frame_records = false;
    pipeline::Run run(world.rig, config, ropt);

    std::vector<LapRow> laps;
    LapRow lap;
    Eigen::Vector2d start(0.0, 0.0);
    bool left_start = false;
    double lap_sq = 0.0, lap_odom_sq = 0.0;
    int lap_frames = 0;
    std::vector<double> frame_ms, paging_ms;  // per frame, whole run
    std::vector<double> paging_after_lap1;
    int64_t checks_seen = 0;
    Timer frame_timer;
    sim::SimFrame sf;
    int produced = 0;
    std::string error;

    const pipeline::FrameSource source = [&](io::LogFrame* out, Status*) {
      if (produced >= frames) return false;
      simulator->next(&sf);
      ++produced;
      out->index = sf.index;
      out->stereo = sf.stereo;
      out->odometry = sf.odometry;
      out->odometry_synthetic = false;
      out->ground_truth.reset();  // the pipeline does not read it; the bench keeps sf's
      frame_timer.restart();
      return true;
    };
    pipeline::RunCallbacks callbacks;
    Pose2 est;
    callbacks.on_frame = [&](const pipeline::RunFrame& f) {
      est = f.output.pose;
      return session->addFrame(f);
    };
    callbacks.between_frames = [&](pipeline::Pipeline* pipe) {
      const Status s = session->betweenFrames(pipe);
      session->takePagedOut();  // copies for evaluation: none here
      // Paging time of this frame: the working-set checks it ran.
      double page_ms = 0.0;
      if (const pipeline::WorkingSetStats* ws = session->workingSet()) {
        for (; checks_seen < ws->checks; ++checks_seen)
          page_ms += ws->check_ms[static_cast<size_t>(checks_seen)];
      }
      frame_ms.push_back(frame_timer.elapsedMs());
      paging_ms.push_back(page_ms);
      if (!laps.empty()) paging_after_lap1.push_back(page_ms);

      const Eigen::Vector3d t_true = sf.ground_truth.T_w_b.translation();
      const double dx = est.x_m - t_true.x(), dy = est.y_m - t_true.y();
      const double ox = sf.odometry.pose.x_m - t_true.x(), oy = sf.odometry.pose.y_m - t_true.y();
      lap_sq += dx * dx + dy * dy;
      lap_odom_sq += ox * ox + oy * oy;
      ++lap_frames;
      lap.confirmations += pipe->report().confirmed;
      lap.reassociated += pipe->report().reassociated;
      lap.frame_ms_mean += frame_ms.back();
      lap.paging_ms_mean += page_ms;

      const Eigen::Vector2d here(t_true.x(), t_true.y());
      if (sf.index == 0) start = here;
      const double from_start = (here - start).norm();
      if (from_start > kLeaveRadiusM) left_start = true;
      const bool lap_end = (left_start && from_start < kLapRadiusM) || produced == frames;
      if (lap_end) {
        left_start = false;
        lap.lap = static_cast<int>(laps.size()) + 1;
        lap.end_frame = sf.index;
        lap.rss_mb = residentMegabytes();
        lap.tracker_confirmed = pipe->database().numConfirmed();
        lap.tracker_candidates = pipe->database().numCandidates();
        lap.map_landmarks = session->recorder() ? session->recorder()->landmarksWritten() : 0;
        lap.map_file_mb = fileMegabytes(map_path);
        if (const pipeline::WorkingSetStats* ws = session->workingSet()) {
          lap.paged_out = ws->paged_out;
          lap.paged_in = ws->paged_in;
        }
        lap.frame_ms_mean /= lap_frames;
        lap.paging_ms_mean /= lap_frames;
        lap.pos_rmse_m = std::sqrt(lap_sq / lap_frames);
        lap.odom_rmse_m = std::sqrt(lap_odom_sq / lap_frames);
        laps.push_back(lap);
        std::fprintf(stderr,
                     "lap %d frame %d rss %.1f MB tracker %d map %lld (%.1f MB) paged out %lld "
                     "in %lld confirmations %d pos %.3f m odom %.3f m frame %.2f ms paging %.3f "
                     "ms\n",
                     lap.lap,
                     lap.end_frame,
                     lap.rss_mb,
                     lap.tracker_confirmed,
                     static_cast<long long>(lap.map_landmarks),
                     lap.map_file_mb,
                     static_cast<long long>(lap.paged_out),
                     static_cast<long long>(lap.paged_in),
                     lap.confirmations,
                     lap.pos_rmse_m,
                     lap.odom_rmse_m,
                     lap.frame_ms_mean,
                     lap.paging_ms_mean);
        lap = LapRow{};
        lap_sq = lap_odom_sq = 0.0;
        lap_frames = 0;
      }
      return s;
    };
    const Status s = run.execute(source, world_path, std::nullopt, callbacks);
    if (!s) error = s.message();
    if (error.empty()) {
      if (Status f = session->finish(); !f) error = f.message();
    }
    const double final_file_mb = fileMegabytes(map_path);
    std::vector<double> ws_steps;
    if (const pipeline::WorkingSetStats* ws = session->workingSet()) {
      ws_steps = {ws->scan_ms, ws->out_ms, ws->query_ms, ws->in_ms};
    }
    session.reset();
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(map_path + suffix);
    if (!error.empty()) {
      state.SkipWithError(error.c_str());
      return;
    }

    if (!csv_prefix.empty()) {
      const std::string path =
          csv_prefix + (working_set ? "_working_set.csv" : "_all_in_memory.csv");
      std::ofstream csv(path);
      csv << "lap,end_frame,rss_mb,tracker_confirmed,tracker_candidates,map_landmarks,map_file_mb,"
             "paged_out,paged_in,confirmations,reassociated,frame_ms_mean,paging_ms_mean,"
             "pos_rmse_m,odom_rmse_m\n";
      for (const LapRow& r : laps) {
        csv << r.lap << ',' << r.end_frame << ',' << r.rss_mb << ',' << r.tracker_confirmed << ','
            << r.tracker_candidates << ',' << r.map_landmarks << ',' << r.map_file_mb << ','
            << r.paged_out << ',' << r.paged_in << ',' << r.confirmations << ',' << r.reassociated
            << ',' << r.frame_ms_mean << ',' << r.paging_ms_mean << ',' << r.pos_rmse_m << ','
            << r.odom_rmse_m << '\n';
      }
    }
    state.counters["frames"] = frames;
    state.counters["laps"] = static_cast<double>(laps.size());
    if (laps.size() >= 2) {
      const LapRow& first = laps.front();
      const LapRow& last = laps.back();
      state.counters["rss_MB_lap1"] = first.rss_mb;
      state.counters["rss_MB_last"] = last.rss_mb;
      // Growth after the first lap, per 1000 frames [MB].
      state.counters["rss_MB_per_kframe_after_lap1"] =
          (last.rss_mb - first.rss_mb) * 1000.0 / std::max(1, last.end_frame - first.end_frame);
      state.counters["map_landmarks_lap1"] = static_cast<double>(first.map_landmarks);
      state.counters["map_landmarks_last"] = static_cast<double>(last.map_landmarks);
      state.counters["tracker_max"] = static_cast<double>(
          std::max_element(laps.begin(), laps.end(), [](const LapRow& a, const LapRow& b) {
            return a.tracker_confirmed < b.tracker_confirmed;
          })->tracker_confirmed);
      state.counters["confirmations_lap2"] = laps[1].confirmations;
      state.counters["pos_rmse_m_lap2"] = laps[1].pos_rmse_m;
      state.counters["pos_rmse_m_last"] = last.pos_rmse_m;
    }
    if (!ws_steps.empty()) {
      state.counters["paging_scan_ms_per_frame"] = ws_steps[0] / frames;
      state.counters["paging_out_ms_per_frame"] = ws_steps[1] / frames;
      state.counters["paging_query_ms_per_frame"] = ws_steps[2] / frames;
      state.counters["paging_in_ms_per_frame"] = ws_steps[3] / frames;
    }
    state.counters["map_file_MB"] = final_file_mb;
    state.counters["frame_ms_median"] = median(frame_ms);
    state.counters["paging_ms_median"] = median(paging_after_lap1);
    state.counters["paging_ms_mean"] = mean(paging_after_lap1);
    state.counters["paging_ms_p95"] = percentile(paging_after_lap1, 0.95);
  }
}

BENCHMARK_CAPTURE(BM_MapLongRun, all_in_memory, false)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK_CAPTURE(BM_MapLongRun, working_set, true)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace
}  // namespace twocam

BENCHMARK_MAIN();
