// Dense 1-D SAD (frontend/dense_sad.h) against OpenCV's StereoBM and StereoSGBM on the shared
// seeded 640x480 pair with 64 disparities, single thread, in one binary so the timings share
// the machine's load. Run:
//   build/<dir>/tests/bench/frontend_bench --benchmark_filter='Dense|Stereo'
//       --benchmark_repetitions=5   (one command line)
// and compare medians.

#include <benchmark/benchmark.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "bench_data.h"
#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"

namespace twocam::bench {
namespace {

constexpr int kBenchDisparities = 64;

// Fraction of pixels whose estimate is within 1 px of the truth, so a run that got faster by
// breaking shows up next to its time.
double goodFraction(const ImageF32& estimate, const ImageF32& truth) {
  size_t good = 0;
  for (size_t i = 0; i < truth.data.size(); ++i) {
    const float d = estimate.data[i];
    if (d >= 0.0f && std::abs(d - truth.data[i]) <= 1.0f) ++good;
  }
  return static_cast<double>(good) / static_cast<double>(truth.data.size());
}

void runDenseSad(benchmark::State& state, const std::vector<frontend::PostStep>& steps) {
  const BenchStereoPair& pair = benchStereoPair();
  frontend::DenseSadOptions options;
  options.max_disparity_px = kBenchDisparities - 1;
  options.steps = steps;
  frontend::DenseSadMatcher matcher;
  ImageF32 disparity;
  for (auto _ : state) {
    const Status status = matcher.compute(pair.left, pair.right, options, &disparity);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(disparity.data.data());
    benchmark::ClobberMemory();
  }
  state.counters["good1"] = goodFraction(disparity, pair.disparity);
  state.counters["MP/s"] =
      benchmark::Counter(static_cast<double>(pair.left.width) * pair.left.height * 1e-6 *
                             static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}

void BM_DenseSadPlain(benchmark::State& state) {
  cv::setNumThreads(1);
  runDenseSad(state, {});
}
BENCHMARK(BM_DenseSadPlain)->Unit(benchmark::kMillisecond);

void BM_DenseSadFull(benchmark::State& state) {
  cv::setNumThreads(1);
  runDenseSad(state,
              {frontend::PostStep::kLeftRightCheck,
               frontend::PostStep::kPropagation,
               frontend::PostStep::kMedian});
}
BENCHMARK(BM_DenseSadFull)->Unit(benchmark::kMillisecond);

// OpenCV outputs disparity * 16 in CV_16S; negative (minDisparity - 1) * 16 marks no estimate.
ImageF32 fromCvDisparity(const cv::Mat& disparity16) {
  cv::Mat as_float;
  disparity16.convertTo(as_float, CV_32F, 1.0 / 16.0);
  return frontend::toImageF32(as_float);
}

void BM_CvStereoBM(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const cv::Mat left = frontend::asMat(pair.left);
  const cv::Mat right = frontend::asMat(pair.right);
  // blockSize 7 to match our window's pixel count order of magnitude (BM's window is 7x7).
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(kBenchDisparities, 7);
  cv::Mat disparity;
  for (auto _ : state) {
    bm->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  state.counters["good1"] = goodFraction(fromCvDisparity(disparity), pair.disparity);
  state.counters["MP/s"] =
      benchmark::Counter(static_cast<double>(pair.left.width) * pair.left.height * 1e-6 *
                             static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CvStereoBM)->Unit(benchmark::kMillisecond);

void BM_CvStereoSGBM(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const cv::Mat left = frontend::asMat(pair.left);
  const cv::Mat right = frontend::asMat(pair.right);
  // OpenCV's documented starting point: P1 = 8 * cn * bs^2, P2 = 32 * cn * bs^2, MODE_SGBM.
  constexpr int kBlock = 5;
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0,
                                                        kBenchDisparities,
                                                        kBlock,
                                                        8 * kBlock * kBlock,
                                                        32 * kBlock * kBlock,
                                                        1,
                                                        0,
                                                        10,
                                                        100,
                                                        1,
                                                        cv::StereoSGBM::MODE_SGBM);
  cv::Mat disparity;
  for (auto _ : state) {
    sgbm->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  state.counters["good1"] = goodFraction(fromCvDisparity(disparity), pair.disparity);
  state.counters["MP/s"] =
      benchmark::Counter(static_cast<double>(pair.left.width) * pair.left.height * 1e-6 *
                             static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CvStereoSGBM)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace twocam::bench
