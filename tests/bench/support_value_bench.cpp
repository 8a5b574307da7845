// Support-value matcher (frontend/support_value.h), dense and salient, against 1-D SAD
// (DenseSadMatcher, matchSalient) and OpenCV's StereoBM and StereoSGBM in the same run, single
// thread: on Middlebury Tsukuba (384x288, disparities 0..16; skipped when ../shared/data is
// absent) and on the shared seeded 640x480 pair with 64 disparities (bench_data.h). Run:
//   taskset -c 1 build/release/tests/bench/frontend_bench
//       --benchmark_filter='SupportValue|Tsukuba|DenseSad|CvStereo|SalientSad/'
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true   (one command line)
// and compare medians; the s/MP counter is the papers' unit.

#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "bench_data.h"
#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"
#include "frontend/salient_sad.h"
#include "frontend/support_value.h"

namespace twocam::bench {
namespace {

constexpr int kTsukubaMaxDisparity = 16;
constexpr int kBenchMaxDisparity = 63;
constexpr int kSalientCorners = 1000;

struct TsukubaPair {
  ImageU8 left;
  ImageU8 right;
  bool ok = false;
};

/// Tsukuba from ../shared/data next to the project (found from this file's path).
const TsukubaPair& tsukuba() {
  static const TsukubaPair kPair = [] {
    TsukubaPair p;
    const std::filesystem::path root =
        std::filesystem::path(__FILE__).parent_path().parent_path().parent_path();
    const std::filesystem::path dir = root / ".." / "shared" / "data" / "middlebury" / "tsukuba";
    p.ok = frontend::loadGrey((dir / "im3.png").string(), &p.left).isOk() &&
           frontend::loadGrey((dir / "im4.png").string(), &p.right).isOk();
    return p;
  }();
  return kPair;
}

void setRate(benchmark::State& state, const ImageU8& image) {
  const double mp = static_cast<double>(image.width) * image.height * 1e-6;
  state.counters["MP/s"] =
      benchmark::Counter(mp * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  // Seconds per megapixel: the inverse rate (Google Benchmark divides by the CPU time).
  state.counters["s/MP"] =
      benchmark::Counter(mp * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

frontend::Simd simdArg(int64_t arg) {
  return arg == 0 ? frontend::Simd::kScalar : frontend::Simd::kAvx2;
}

void runSupportDense(benchmark::State& state,
                     const ImageU8& left,
                     const ImageU8& right,
                     frontend::SupportValueOptions options) {
  cv::setNumThreads(1);
  if (!frontend::simdAvailable(options.simd)) {
    state.SkipWithError("SIMD choice not available on this CPU");
    return;
  }
  frontend::SupportValueMatcher matcher;
  ImageF32 disparity;
  for (auto _ : state) {
    const Status status = matcher.compute(left, right, options, &disparity);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(disparity.data.data());
    benchmark::ClobberMemory();
  }
  state.counters["validated%"] = 100.0 * static_cast<double>(matcher.stats().validated) /
                                 static_cast<double>(left.data.size());
  setRate(state, left);
}

/// Args: {simd (0 baseline build, 1 AVX2 + POPCNT), weighting (0 equal, 1 decreasing)}.
void BM_SupportValueTsukuba(benchmark::State& state) {
  const TsukubaPair& p = tsukuba();
  if (!p.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  frontend::SupportValueOptions o;
  o.max_disparity_px = kTsukubaMaxDisparity;
  o.simd = simdArg(state.range(0));
  o.weighting = state.range(1) == 0 ? frontend::SupportWeighting::kEqual
                                    : frontend::SupportWeighting::kDecreasing;
  runSupportDense(state, p.left, p.right, o);
}
BENCHMARK(BM_SupportValueTsukuba)
    ->ArgNames({"avx2", "decreasing"})
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMillisecond);

/// Args: {window_px}: the packed structure takes ceil(window^2 / 64) words (9: 2, 13: 3, 15: 4,
/// 19: 6 with the generic kernel).
void BM_SupportValueWindow(benchmark::State& state) {
  const BenchStereoPair& pair = benchStereoPair();
  frontend::SupportValueOptions o;
  o.max_disparity_px = kBenchMaxDisparity;
  o.window_px = static_cast<int>(state.range(0));
  runSupportDense(state, pair.left, pair.right, o);
}
BENCHMARK(BM_SupportValueWindow)
    ->ArgNames({"window"})
    ->Arg(9)
    ->Arg(13)
    ->Arg(15)
    ->Arg(19)
    ->Unit(benchmark::kMillisecond);

void BM_DenseSadTsukuba(benchmark::State& state) {
  cv::setNumThreads(1);
  const TsukubaPair& p = tsukuba();
  if (!p.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  frontend::DenseSadOptions o;  // Paper C's lrc,prop,median
  o.max_disparity_px = kTsukubaMaxDisparity;
  frontend::DenseSadMatcher matcher;
  ImageF32 disparity;
  for (auto _ : state) {
    const Status status = matcher.compute(p.left, p.right, o, &disparity);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(disparity.data.data());
    benchmark::ClobberMemory();
  }
  setRate(state, p.left);
}
BENCHMARK(BM_DenseSadTsukuba)->Unit(benchmark::kMillisecond);

/// Args: {0 StereoBM block 13, 1 StereoSGBM block 5}; 16 disparities (OpenCV wants a multiple of
/// 16: 0..15, one fewer than ours).
void BM_CvTsukuba(benchmark::State& state) {
  cv::setNumThreads(1);
  const TsukubaPair& p = tsukuba();
  if (!p.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  const cv::Mat left = frontend::asMat(p.left);
  const cv::Mat right = frontend::asMat(p.right);
  constexpr int kSgbmBlock = 5;
  cv::Ptr<cv::StereoMatcher> matcher;
  if (state.range(0) == 0) {
    matcher = cv::StereoBM::create(16, 13);
  } else {
    matcher = cv::StereoSGBM::create(0,
                                     16,
                                     kSgbmBlock,
                                     8 * kSgbmBlock * kSgbmBlock,
                                     32 * kSgbmBlock * kSgbmBlock,
                                     1,
                                     0,
                                     10,
                                     100,
                                     1,
                                     cv::StereoSGBM::MODE_SGBM);
  }
  cv::Mat disparity;
  for (auto _ : state) {
    matcher->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  setRate(state, p.left);
}
BENCHMARK(BM_CvTsukuba)->ArgNames({"sgbm"})->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

/// The shared 640x480 pair, 64 disparities (compare BM_DenseSadFull, BM_CvStereoBM/SGBM).
void BM_SupportValueDense640(benchmark::State& state) {
  const BenchStereoPair& pair = benchStereoPair();
  frontend::SupportValueOptions o;
  o.max_disparity_px = kBenchMaxDisparity;
  o.simd = simdArg(state.range(0));
  runSupportDense(state, pair.left, pair.right, o);
}
BENCHMARK(BM_SupportValueDense640)
    ->ArgNames({"avx2"})
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond);

std::vector<Corner> harrisCorners(const ImageU8& image, int count) {
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

/// Args: {lr (0: no left-right check, 1: with)} at 1000 corners of the 640x480 pair, 64
/// disparities (compare BM_SalientSad/1000/1 of salient_bench.cpp).
void BM_SupportValueSalient(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const std::vector<Corner> corners = harrisCorners(pair.left, kSalientCorners);
  frontend::SupportValueOptions o;
  o.max_disparity_px = kBenchMaxDisparity;
  o.lr_tolerance_px = state.range(0) == 0 ? -1 : 1;
  StereoHypotheses out;
  for (auto _ : state) {
    const Status s = frontend::matchSupportValueSalient(pair.left, pair.right, corners, o, &out);
    if (!s) state.SkipWithError(s.message().c_str());
    benchmark::DoNotOptimize(out.hypotheses.data());
    benchmark::ClobberMemory();
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  state.counters["hyps/pt"] =
      static_cast<double>(out.hypotheses.size()) / static_cast<double>(out.points.size());
}
BENCHMARK(BM_SupportValueSalient)->ArgNames({"lr"})->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace twocam::bench
