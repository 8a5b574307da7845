// 1-D Max-Tree stereo (frontend/maxtree.h) against 1-D SAD (dense and salient) and OpenCV's
// StereoBM and StereoSGBM on Middlebury Tsukuba (384x288, 16 disparities), single thread, in
// one binary so the timings share the machine's load. Also the Max-Tree matcher on the seeded
// 640x480 pair of bench_data.h beside BM_DenseSad*. Run:
//   taskset -c 1 build/<dir>/tests/bench/frontend_bench --benchmark_filter='Tsukuba|MaxTree'
//       --benchmark_repetitions=5   (one command line)
// and compare medians; the s/MP counters are the papers' unit.

#include <benchmark/benchmark.h>

#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "bench_data.h"
#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"
#include "frontend/harris.h"
#include "frontend/maxtree.h"
#include "frontend/salient_sad.h"

namespace twocam::bench {
namespace {

constexpr int kTsukubaMaxDisparity = 16;
/// 1000 corners per 640x480, the stereo-eval default (docs/frontend.md).
constexpr double kCornersPerMp = 3255.0;

struct Tsukuba {
  ImageU8 left;
  ImageU8 right;
  bool ok = false;
};

/// ../shared/data next to the project, as tests/support/test_paths.h finds it.
const Tsukuba& tsukuba() {
  static const Tsukuba kPair = [] {
    Tsukuba t;
    const std::filesystem::path dir = std::filesystem::path(__FILE__).parent_path() / ".." / ".." /
                                      ".." / "shared" / "data" / "middlebury" / "tsukuba";
    t.ok = frontend::loadGrey((dir / "im3.png").string(), &t.left).isOk() &&
           frontend::loadGrey((dir / "im4.png").string(), &t.right).isOk();
    return t;
  }();
  return kPair;
}

void setRate(benchmark::State& state, const ImageU8& image) {
  const double mp = static_cast<double>(image.width) * image.height * 1e-6;
  state.counters["s/MP"] =
      benchmark::Counter(mp * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void runMaxTree(benchmark::State& state, const ImageU8& left, const ImageU8& right, int max_d) {
  frontend::MaxTreeOptions options;
  options.max_disparity_px = max_d;
  frontend::MaxTreeMatcher matcher;
  frontend::MaxTreeResult result;
  for (auto _ : state) {
    const Status status = matcher.compute(left, right, options, &result);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(result.points.data());
    benchmark::ClobberMemory();
  }
  state.counters["points"] = static_cast<double>(result.points.size());
  setRate(state, left);
}

void BM_MaxTreeTsukuba(benchmark::State& state) {
  const Tsukuba& t = tsukuba();
  if (!t.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  runMaxTree(state, t.left, t.right, kTsukubaMaxDisparity);
}
BENCHMARK(BM_MaxTreeTsukuba)->Unit(benchmark::kMillisecond);

void BM_MaxTreeSynthetic640(benchmark::State& state) {
  const BenchStereoPair& pair = benchStereoPair();
  runMaxTree(state, pair.left, pair.right, 63);  // the 64 disparities of BM_DenseSad*
}
BENCHMARK(BM_MaxTreeSynthetic640)->Unit(benchmark::kMillisecond);

std::vector<Corner> tsukubaCorners(const ImageU8& left) {
  frontend::HarrisOptions harris;
  harris.target_count =
      static_cast<int>(kCornersPerMp * 1e-6 * static_cast<double>(left.width) * left.height);
  harris.max_corners = 2 * harris.target_count;
  frontend::HarrisDetector detector(harris);
  std::vector<Corner> corners;
  for (int pass = 0; pass < 4; ++pass) (void)detector.detect(left, &corners);
  return corners;
}

// Salient: the whole Max-Tree run plus the look-up at the corners (detection not timed).
void BM_MaxTreeSalientTsukuba(benchmark::State& state) {
  const Tsukuba& t = tsukuba();
  if (!t.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  const std::vector<Corner> corners = tsukubaCorners(t.left);
  frontend::MaxTreeOptions options;
  options.max_disparity_px = kTsukubaMaxDisparity;
  StereoHypotheses hyps;
  for (auto _ : state) {
    const Status status = frontend::matchMaxTreeSalient(t.left, t.right, corners, options, &hyps);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(hyps.hypotheses.data());
    benchmark::ClobberMemory();
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  setRate(state, t.left);
}
BENCHMARK(BM_MaxTreeSalientTsukuba)->Unit(benchmark::kMillisecond);

void BM_SalientSadTsukuba(benchmark::State& state) {
  const Tsukuba& t = tsukuba();
  if (!t.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  const std::vector<Corner> corners = tsukubaCorners(t.left);
  frontend::SalientSadOptions options;
  options.max_disparity_px = kTsukubaMaxDisparity;
  StereoHypotheses hyps;
  for (auto _ : state) {
    const Status status = frontend::matchSalient(t.left, t.right, corners, options, &hyps);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(hyps.hypotheses.data());
    benchmark::ClobberMemory();
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  setRate(state, t.left);
}
BENCHMARK(BM_SalientSadTsukuba)->Unit(benchmark::kMillisecond);

void BM_DenseSadTsukuba(benchmark::State& state) {
  const Tsukuba& t = tsukuba();
  if (!t.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  frontend::DenseSadOptions options;  // defaults: LRC, propagation, median, as stereo-eval
  options.max_disparity_px = kTsukubaMaxDisparity;
  frontend::DenseSadMatcher matcher;
  ImageF32 disparity;
  for (auto _ : state) {
    const Status status = matcher.compute(t.left, t.right, options, &disparity);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(disparity.data.data());
    benchmark::ClobberMemory();
  }
  setRate(state, t.left);
}
BENCHMARK(BM_DenseSadTsukuba)->Unit(benchmark::kMillisecond);

void BM_CvStereoBMTsukuba(benchmark::State& state) {
  cv::setNumThreads(1);
  const Tsukuba& t = tsukuba();
  if (!t.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  const cv::Mat left = frontend::asMat(t.left);
  const cv::Mat right = frontend::asMat(t.right);
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(kTsukubaMaxDisparity, 7);
  cv::Mat disparity;
  for (auto _ : state) {
    bm->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  setRate(state, t.left);
}
BENCHMARK(BM_CvStereoBMTsukuba)->Unit(benchmark::kMillisecond);

void BM_CvStereoSGBMTsukuba(benchmark::State& state) {
  cv::setNumThreads(1);
  const Tsukuba& t = tsukuba();
  if (!t.ok) {
    state.SkipWithError("../shared/data/middlebury/tsukuba is absent");
    return;
  }
  const cv::Mat left = frontend::asMat(t.left);
  const cv::Mat right = frontend::asMat(t.right);
  constexpr int kBlock = 5;  // as BM_CvStereoSGBM: OpenCV's documented starting point
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0,
                                                        kTsukubaMaxDisparity,
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
  setRate(state, t.left);
}
BENCHMARK(BM_CvStereoSGBMTsukuba)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace twocam::bench
