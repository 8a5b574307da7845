/// Whole per-frame pipeline of `twocam run` (frontend + landmark database + occupancy map,
/// pipeline/pipeline.h) on a recorded simulated log, one thread, against the pipeline issue's
/// target of 5 ms median per 640x480 frame.
///
/// The log is read into memory first (decoding is not part of the pipeline, METRICS.md); each
/// benchmark iteration runs a fresh pipeline over every frame and records each frame's stage
/// times. Counters: per-frame median / p95 of the total and median of each stage [ms].
///
///   TWOCAM_BENCH_LOG=out/office.rawlog build/bench/tests/bench/pipeline_bench
///
/// TWOCAM_BENCH_CONFIG=FILE.yaml runs it with that config (as `twocam run --config`); the
/// policy of each benchmark still overrides the file's.
///
/// Without TWOCAM_BENCH_LOG the benchmark looks for out/office.rawlog (the main command's log)
/// under the current folder and skips with a message when there is none.

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "frontend/cv_interop.h"
#include "io/rawlog.h"
#include "localization/options.h"
#include "pipeline/config.h"
#include "pipeline/pipeline.h"

namespace twocam {
namespace {

struct RecordedLog {
  std::string path;
  std::string error;
  StereoRig rig;
  std::vector<io::LogFrame> frames;
};

const RecordedLog& recordedLog() {
  static const RecordedLog kLog = [] {
    RecordedLog l;
    const char* env = std::getenv("TWOCAM_BENCH_LOG");
    l.path = env ? env : "out/office.rawlog";
    std::error_code ec;
    if (!std::filesystem::exists(l.path, ec)) {
      l.error = l.path +
                " not found: set TWOCAM_BENCH_LOG to a rawlog with odometry (e.g. from "
                "scripts/run_demo.sh)";
      return l;
    }
    std::unique_ptr<io::RawlogReader> reader;
    if (Status s = io::RawlogReader::open(l.path, &reader); !s) {
      l.error = s.message();
      return l;
    }
    l.rig = reader->rig();
    io::LogFrame f;
    Status st;
    while (reader->next(&f, &st)) {
      if (f.odometry) l.frames.push_back(f);
      f.ground_truth.reset();
    }
    for (io::LogFrame& fr : l.frames) fr.ground_truth.reset();  // not needed: keep memory down
    if (!st) l.error = st.message();
    if (l.frames.empty() && l.error.empty()) l.error = l.path + ": no frames with odometry";
    return l;
  }();
  return kLog;
}

/// The config of the run: the defaults, or TWOCAM_BENCH_CONFIG's file over them.
Status loadBenchConfig(pipeline::PipelineConfig* config) {
  const char* path = std::getenv("TWOCAM_BENCH_CONFIG");
  return path ? pipeline::loadConfigFile(path, config) : Status::ok();
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t k =
      std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/// Per-frame stage times of every run, reported as medians / p95 [ms].
struct StageSamples {
  std::vector<double> total, frontend, landmarks, localization, mapping;
  void add(const pipeline::StageTimes& t) {
    total.push_back(t.totalMs());
    frontend.push_back(t.frontend_ms);
    landmarks.push_back(t.landmarks_ms);
    localization.push_back(t.localization_ms);
    mapping.push_back(t.mapping_ms);
  }
  void report(benchmark::State& state, const RecordedLog& log) const {
    state.counters["frames"] = static_cast<double>(log.frames.size());
    state.counters["total_median_ms"] = quantile(total, 0.5);
    state.counters["total_p95_ms"] = quantile(total, 0.95);
    state.counters["frontend_median_ms"] = quantile(frontend, 0.5);
    state.counters["landmarks_median_ms"] = quantile(landmarks, 0.5);
    state.counters["localization_median_ms"] = quantile(localization, 0.5);
    state.counters["localization_p95_ms"] = quantile(localization, 0.95);
    state.counters["mapping_median_ms"] = quantile(mapping, 0.5);
    state.counters["width_px"] = log.rig.width_px;
    state.counters["height_px"] = log.rig.height_px;
  }
};

/// `policy` with localisation `mode` (odometry | pnp | fused; the three baselines).
void BM_PipelinePerFrame(benchmark::State& state, const char* policy, const char* mode) {
  const RecordedLog& log = recordedLog();
  if (!log.error.empty()) {
    state.SkipWithError(log.error.c_str());
    return;
  }
  pipeline::PipelineConfig config;
  if (Status s = loadBenchConfig(&config); !s) {
    state.SkipWithError(s.message().c_str());
    return;
  }
  if (Status s = landmarks::parsePolicy(policy, &config.landmarks.policy); !s) {
    state.SkipWithError(s.message().c_str());
    return;
  }
  if (Status s = localization::parseMode(mode, &config.localization.mode); !s) {
    state.SkipWithError(s.message().c_str());
    return;
  }
  if (Status s = pipeline::clampToRig(log.rig, &config); !s) {
    state.SkipWithError(s.message().c_str());
    return;
  }
  StageSamples samples;
  for (auto _ : state) {
    pipeline::Pipeline pipe(log.rig, config);
    pipeline::FrameOutput out;
    for (const io::LogFrame& f : log.frames) {
      if (pipe.process(f.index, f.stereo, f.odometry->pose, &out)) samples.add(out.times);
    }
    benchmark::DoNotOptimize(pipe.database().numConfirmed());
  }
  samples.report(state, log);
}

/// The same landmarks + mapping stages fed by the OpenCV way of getting corners and depth:
/// goodFeaturesToTrack (Harris, as many corners as the pipeline's harris.target_count) and a
/// dense StereoBM (11x11, 64 disparities) read at the corners, one hypothesis per corner. Reference
/// for the frontend's share of the frame budget, not a like-for-like rival (one hypothesis, no
/// rivals).
void BM_PipelineOpenCVFrontend(benchmark::State& state) {
  const RecordedLog& log = recordedLog();
  if (!log.error.empty()) {
    state.SkipWithError(log.error.c_str());
    return;
  }
  cv::setNumThreads(1);
  pipeline::PipelineConfig config;
  if (Status s = loadBenchConfig(&config); !s) {
    state.SkipWithError(s.message().c_str());
    return;
  }
  if (Status s = pipeline::clampToRig(log.rig, &config); !s) {
    state.SkipWithError(s.message().c_str());
    return;
  }
  // As many corners as our frontend's budget (the pipeline's harris.target_count).
  const int max_corners = config.frontend.harris.target_count;
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(64, 11);
  StageSamples samples;
  std::vector<cv::Point2f> corners;
  cv::Mat disparity;
  StereoHypotheses hyps;
  for (auto _ : state) {
    pipeline::Pipeline pipe(log.rig, config);
    pipeline::FrameOutput out;
    for (const io::LogFrame& f : log.frames) {
      const auto t0 = std::chrono::steady_clock::now();
      const cv::Mat left = frontend::asMat(f.stereo.left);
      cv::goodFeaturesToTrack(
          left, corners, max_corners, 0.01, 1.0, cv::noArray(), 3, 3, true, 0.04);
      bm->compute(left, frontend::asMat(f.stereo.right), disparity);
      hyps.clear();
      hyps.t_ns = f.stereo.t_ns;
      for (const cv::Point2f& c : corners) {
        const int u = static_cast<int>(std::lround(c.x));
        const int v = static_cast<int>(std::lround(c.y));
        const int16_t raw = disparity.at<int16_t>(v, u);
        if (raw <= 0) continue;  // StereoBM marks no match with a negative value
        SalientPoint p;
        p.corner.u_px = u;
        p.corner.v_px = v;
        p.first_hypothesis = static_cast<uint32_t>(hyps.hypotheses.size());
        p.num_hypotheses = 1;
        DisparityHypothesis h;
        h.d_px = static_cast<float>(raw) / 16.0f;
        h.point_index = static_cast<uint32_t>(hyps.points.size());
        h.lr_consistent = true;
        hyps.points.push_back(p);
        hyps.hypotheses.push_back(h);
      }
      const double fe_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (!pipe.processHypotheses(f.index, f.stereo.t_ns, f.odometry->pose, hyps, &out)) continue;
      out.times.frontend_ms = fe_ms;
      samples.add(out.times);
    }
    benchmark::DoNotOptimize(pipe.database().numConfirmed());
  }
  samples.report(state, log);
}

BENCHMARK_CAPTURE(BM_PipelinePerFrame, consistency_fused, "consistency", "fused")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_PipelinePerFrame, consistency_pnp, "consistency", "pnp")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_PipelinePerFrame, consistency_odometry, "consistency", "odometry")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(BM_PipelinePerFrame, wta_lrc_fused, "wta-lrc", "fused")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3);
BENCHMARK(BM_PipelineOpenCVFrontend)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace twocam
