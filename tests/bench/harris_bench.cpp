// Harris detection (frontend/harris.h) against OpenCV's cornerHarris and goodFeaturesToTrack on
// the left image of the shared seeded 640x480 pair, single thread, in one binary so the timings
// share the machine's load. Run:
//   build/<dir>/tests/bench/frontend_bench --benchmark_filter=Harris
//       --benchmark_repetitions=5   (one command line)
// and compare medians. cv::cornerHarris computes only the response; ours also suppresses,
// thresholds, sorts and caps.

#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "bench_data.h"
#include "frontend/cv_interop.h"
#include "frontend/harris.h"

namespace twocam::bench {
namespace {

// Arg 1: AVX2 kernels when the CPU has them; 0: the portable build (baseline x86-64 here).
void BM_HarrisDetect(benchmark::State& state) {
  cv::setNumThreads(1);
  const ImageU8& image = benchStereoPair().left;
  frontend::HarrisOptions options;
  options.simd = state.range(0) != 0 ? frontend::Simd::kAuto : frontend::Simd::kScalar;
  frontend::HarrisDetector detector(options);
  std::vector<Corner> corners;
  // Let the threshold settle on this image first, so the timed frames are steady-state frames.
  for (int i = 0; i < 10; ++i) {
    if (!detector.detect(image, &corners).isOk()) state.SkipWithError("detect failed");
  }
  for (auto _ : state) {
    if (!detector.detect(image, &corners).isOk()) state.SkipWithError("detect failed");
    benchmark::DoNotOptimize(corners.data());
    benchmark::ClobberMemory();
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  state.counters["candidates"] = detector.lastCandidateCount();
}
BENCHMARK(BM_HarrisDetect)->ArgName("avx2")->Arg(1)->Arg(0)->Unit(benchmark::kMicrosecond);

// Whole detection with grid bucketing (default grid, cell cap).
void BM_HarrisDetectBucketed(benchmark::State& state) {
  cv::setNumThreads(1);
  const ImageU8& image = benchStereoPair().left;
  frontend::HarrisOptions options;
  options.bucketing = true;
  frontend::HarrisDetector detector(options);
  std::vector<Corner> corners;
  for (int i = 0; i < 10; ++i) {
    if (!detector.detect(image, &corners).isOk()) state.SkipWithError("detect failed");
  }
  for (auto _ : state) {
    if (!detector.detect(image, &corners).isOk()) state.SkipWithError("detect failed");
    benchmark::DoNotOptimize(corners.data());
    benchmark::ClobberMemory();
  }
  state.counters["corners"] = static_cast<double>(corners.size());
}
BENCHMARK(BM_HarrisDetectBucketed)->Unit(benchmark::kMicrosecond);

void BM_HarrisResponse(benchmark::State& state) {
  cv::setNumThreads(1);
  const ImageU8& image = benchStereoPair().left;
  frontend::HarrisOptions options;
  options.simd = state.range(0) != 0 ? frontend::Simd::kAuto : frontend::Simd::kScalar;
  ImageF32 response;
  for (auto _ : state) {
    if (!frontend::harrisResponse(image, options, &response).isOk()) {
      state.SkipWithError("harrisResponse failed");
    }
    benchmark::DoNotOptimize(response.data.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_HarrisResponse)->ArgName("avx2")->Arg(1)->Arg(0)->Unit(benchmark::kMicrosecond);

// Arg: blockSize. 3 places corners closest to ours, 5 has our window's extent (flat weights).
void BM_CvCornerHarris(benchmark::State& state) {
  cv::setNumThreads(1);
  const cv::Mat image = frontend::asMat(benchStereoPair().left);
  const int block_size = static_cast<int>(state.range(0));
  cv::Mat response;
  for (auto _ : state) {
    cv::cornerHarris(image, response, block_size, 3, 0.04);
    benchmark::DoNotOptimize(response.data);
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_CvCornerHarris)->ArgName("block")->Arg(3)->Arg(5)->Unit(benchmark::kMicrosecond);

// OpenCV's complete Harris detector: response, 3x3 dilation for the maxima, quality threshold
// (1% of the best), sort, cap at 1000 (minDistance 1 adds no spacing beyond the suppression).
// Arg useHarris: 1 = Harris response (block 3, the closest to ours), 0 = Shi-Tomasi; the arg
// name also puts it under --benchmark_filter=Harris.
void BM_CvGoodFeaturesToTrack(benchmark::State& state) {
  cv::setNumThreads(1);
  const cv::Mat image = frontend::asMat(benchStereoPair().left);
  const bool use_harris = state.range(0) != 0;
  std::vector<cv::Point2f> corners;
  for (auto _ : state) {
    cv::goodFeaturesToTrack(image, corners, 1000, 0.01, 1.0, cv::noArray(), 3, 3, use_harris, 0.04);
    benchmark::DoNotOptimize(corners.data());
    benchmark::ClobberMemory();
  }
  state.counters["corners"] = static_cast<double>(corners.size());
}
BENCHMARK(BM_CvGoodFeaturesToTrack)->ArgName("useHarris")->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace twocam::bench
