/// Salient 1-D SAD and Paper A corner pairing on the shared 640x480 bench pair (bench_data.h).
/// Corners come from OpenCV's Harris (goodFeaturesToTrack), built outside the timed loops.
/// One thread everywhere (cv::setNumThreads(1)); compare figures from the same run only.

#include <benchmark/benchmark.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "bench_data.h"
#include "frontend/corner_pairing.h"
#include "frontend/cv_interop.h"
#include "frontend/row_support.h"
#include "frontend/salient_sad.h"

namespace twocam::bench {
namespace {

/// Up to `count` Harris corners of `image`, strongest first (minimum distance 2 px so that
/// 4000 fit in 640x480).
std::vector<Corner> benchCorners(const ImageU8& image, int count) {
  std::vector<cv::Point2f> pts;
  cv::goodFeaturesToTrack(frontend::asMat(image), pts, count, 1e-4, 2.0, cv::noArray(), 3, true);
  std::vector<Corner> corners;
  corners.reserve(pts.size());
  for (const cv::Point2f& p : pts) {
    corners.push_back(
        {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y)), 1.0f});
  }
  return corners;
}

void runSalient(benchmark::State& state, frontend::SalientSadOptions options, int count) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const std::vector<Corner> corners = benchCorners(pair.left, count);
  StereoHypotheses out;
  for (auto _ : state) {
    const Status s = frontend::matchSalient(pair.left, pair.right, corners, options, &out);
    benchmark::DoNotOptimize(s);
    benchmark::DoNotOptimize(out.hypotheses.data());
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  state.counters["hyps_per_point"] =
      static_cast<double>(out.hypotheses.size()) / static_cast<double>(out.points.size());
  state.counters["ns_per_corner"] = benchmark::Counter(
      static_cast<double>(corners.size()),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// Args: {corners, lr_check}. Default options (W = 11, disparities 0..63, shiftable windows),
/// kernel chosen for this CPU.
void BM_SalientSad(benchmark::State& state) {
  frontend::SalientSadOptions options;
  options.lr_check = state.range(1) != 0;
  runSalient(state, options, static_cast<int>(state.range(0)));
}
BENCHMARK(BM_SalientSad)
    ->ArgNames({"corners", "lr"})
    ->ArgsProduct({{250, 1000, 2500, 4000}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

/// Args: {row_support}: matching at 2500 corners (the `twocam run` budget) with and without
/// measureRowSupport afterwards, to price the row support the landmark database reads.
void BM_SalientSadRowSupport(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const std::vector<Corner> corners = benchCorners(pair.left, 2500);
  const frontend::SalientSadOptions options;
  const bool rows = state.range(0) != 0;
  StereoHypotheses out;
  for (auto _ : state) {
    Status s = frontend::matchSalient(pair.left, pair.right, corners, options, &out);
    if (rows && s.isOk()) s = frontend::measureRowSupport(pair.left, pair.right, options, &out);
    benchmark::DoNotOptimize(s);
    benchmark::DoNotOptimize(out.hypotheses.data());
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  state.counters["hypotheses"] = static_cast<double>(out.hypotheses.size());
  state.counters["ns_per_hypothesis"] = benchmark::Counter(
      static_cast<double>(out.hypotheses.size()),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SalientSadRowSupport)
    ->ArgNames({"rows"})
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond);

/// measureRowSupport alone on the hypotheses of 2500 corners (matched once, outside the loop).
void BM_MeasureRowSupport(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const std::vector<Corner> corners = benchCorners(pair.left, 2500);
  const frontend::SalientSadOptions options;
  StereoHypotheses out;
  if (!frontend::matchSalient(pair.left, pair.right, corners, options, &out).isOk()) {
    state.SkipWithError("matching failed");
    return;
  }
  for (auto _ : state) {
    const Status s = frontend::measureRowSupport(pair.left, pair.right, options, &out);
    benchmark::DoNotOptimize(s);
    benchmark::DoNotOptimize(out.hypotheses.data());
  }
  state.counters["hypotheses"] = static_cast<double>(out.hypotheses.size());
  state.counters["ns_per_hypothesis"] = benchmark::Counter(
      static_cast<double>(out.hypotheses.size()),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_MeasureRowSupport)->Unit(benchmark::kMicrosecond);

/// Args: {kernel, lr_check} at 1000 corners: 1 scalar, 2 SSE2, 3 AVX2 (skipped if absent).
void BM_SalientSadKernel(benchmark::State& state) {
  frontend::SalientSadOptions options;
  options.simd = static_cast<frontend::Simd>(state.range(0));
  options.lr_check = state.range(1) != 0;
  if (!frontend::simdAvailable(options.simd)) {
    state.SkipWithError("kernel not available on this CPU");
    return;
  }
  runSalient(state, options, 1000);
}
BENCHMARK(BM_SalientSadKernel)
    ->ArgNames({"kernel", "lr"})
    ->ArgsProduct({{1, 2, 3}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

/// Args: {lr_check}: the centred window only (Paper B as published; shiftable_windows off) at
/// 1000 corners, to price the default shiftable windows.
void BM_SalientSadCentred(benchmark::State& state) {
  frontend::SalientSadOptions options;
  options.shiftable_windows = false;
  options.lr_check = state.range(0) != 0;
  runSalient(state, options, 1000);
}
BENCHMARK(BM_SalientSadCentred)->ArgNames({"lr"})->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

/// Args: {shiftable_windows, lr_check}: zero-mean SAD at 1000 corners.
void BM_SalientSadZeroMean(benchmark::State& state) {
  frontend::SalientSadOptions options;
  options.zero_mean = true;
  options.shiftable_windows = state.range(0) != 0;
  options.lr_check = state.range(1) != 0;
  runSalient(state, options, 1000);
}
BENCHMARK(BM_SalientSadZeroMean)
    ->ArgNames({"shiftable", "lr"})
    ->ArgsProduct({{0, 1}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

/// Args: {corners, lr_check}: the sampling-insensitive (Birchfield-Tomasi) cost `twocam run`
/// uses, including the interval images of both views it builds per call; BM_SalientSad at the
/// same counts is plain SAD.
void BM_SalientSadBirchfieldTomasi(benchmark::State& state) {
  frontend::SalientSadOptions options;
  options.birchfield_tomasi = true;
  options.lr_check = state.range(1) != 0;
  runSalient(state, options, static_cast<int>(state.range(0)));
}
BENCHMARK(BM_SalientSadBirchfieldTomasi)
    ->ArgNames({"corners", "lr"})
    ->ArgsProduct({{1000, 2500}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

/// Args: {corners per image, row tolerance m}: Paper A pairing, right corners detected on the
/// right image.
void BM_PairCorners(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const int count = static_cast<int>(state.range(0));
  const std::vector<Corner> left = benchCorners(pair.left, count);
  const std::vector<Corner> right = benchCorners(pair.right, count);
  frontend::SalientSadOptions options;
  options.row_tolerance_px = static_cast<int>(state.range(1));
  StereoHypotheses out;
  for (auto _ : state) {
    const Status s = frontend::pairCorners(pair.left, pair.right, left, right, options, &out);
    benchmark::DoNotOptimize(s);
    benchmark::DoNotOptimize(out.hypotheses.data());
  }
  state.counters["corners"] = static_cast<double>(left.size());
  state.counters["hyps_per_point"] =
      static_cast<double>(out.hypotheses.size()) / static_cast<double>(out.points.size());
}
BENCHMARK(BM_PairCorners)
    ->ArgNames({"corners", "m"})
    ->ArgsProduct({{250, 1000, 4000}, {0, 1}})
    ->Unit(benchmark::kMicrosecond);

/// Reference point, not a like-for-like rival: OpenCV's dense block matcher over the whole
/// frame (11x11 windows, 64 disparities), what a dense SAD costs per frame on this CPU.
void BM_SalientReferenceOpenCvStereoBM(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const cv::Mat left = frontend::asMat(pair.left);
  const cv::Mat right = frontend::asMat(pair.right);
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(64, 11);
  cv::Mat disparity;
  for (auto _ : state) {
    bm->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
  }
}
BENCHMARK(BM_SalientReferenceOpenCvStereoBM)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace twocam::bench
