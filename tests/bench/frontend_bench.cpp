// The whole frontend per stereo frame (frontend/frontend.h: Harris on the left image, then salient
// hypotheses) against what one would do with OpenCV for the same frame (goodFeaturesToTrack +
// StereoBM on the full frame), on the shared seeded 640x480 pair, single thread, in one binary so
// the timings share the machine's load. Issue target: the whole frontend within 2 ms per frame on
// one core. Run:
//   build/<dir>/tests/bench/frontend_bench --benchmark_filter='Frontend|GFTT'
//       --benchmark_repetitions=5   (one command line)
// and compare medians.

#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "bench_data.h"
#include "common/frames.h"
#include "frontend/cv_interop.h"
#include "frontend/frontend.h"

namespace twocam::bench {
namespace {

constexpr int kBenchDisparities = 64;
// The Harris threshold adapts from frame to frame; these frames let it settle on the bench pair
// so the timed frames are steady-state frames (as in harris_bench.cpp).
constexpr int kWarmupFrames = 10;

void runFrontend(benchmark::State& state, frontend::HypothesisSource source) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  StereoFrame frame;
  frame.left = pair.left;
  frame.right = pair.right;
  frontend::FrontendOptions options;
  options.sad.max_disparity_px = kBenchDisparities - 1;  // disparities 0..63
  options.source = source;
  frontend::Frontend frontend(options);
  StereoHypotheses out;
  for (int i = 0; i < kWarmupFrames; ++i) {
    if (!frontend.process(frame, &out).isOk()) state.SkipWithError("process failed");
  }
  // The frontend's own split of each frame, so a change in the total can be placed.
  double harris_ms = 0.0;
  double matching_ms = 0.0;
  for (auto _ : state) {
    frame.t_ns += 1;
    const Status status = frontend.process(frame, &out);
    if (!status) state.SkipWithError(status.message().c_str());
    benchmark::DoNotOptimize(out.hypotheses.data());
    benchmark::ClobberMemory();
    harris_ms += frontend.timing().harris_ms;
    matching_ms += frontend.timing().matching_ms;
  }
  const double iterations = static_cast<double>(state.iterations());
  state.SetItemsProcessed(state.iterations());
  state.counters["corners"] = static_cast<double>(frontend.corners().size());
  state.counters["points"] = static_cast<double>(out.points.size());
  state.counters["hypotheses"] = static_cast<double>(out.hypotheses.size());
  state.counters["harris_ms"] = harris_ms / iterations;
  state.counters["matching_ms"] = matching_ms / iterations;
}

// Default options (Paper B: 1-D SAD at every left corner, W = 11, shiftable windows), 64
// disparities.
void BM_Frontend_Process(benchmark::State& state) {
  runFrontend(state, frontend::HypothesisSource::kSad);
}
BENCHMARK(BM_Frontend_Process)->Unit(benchmark::kMicrosecond);

// Paper A: Harris on both images, every right corner in the search window is a hypothesis.
void BM_Frontend_ProcessPairing(benchmark::State& state) {
  runFrontend(state, frontend::HypothesisSource::kCornerPairing);
}
BENCHMARK(BM_Frontend_ProcessPairing)->Unit(benchmark::kMicrosecond);

// Reference, not a like-for-like rival: the OpenCV way to get corners and depth for one frame.
// goodFeaturesToTrack as in harris_bench.cpp (Harris response, block 3, 1000 corners, quality
// 1%), then a dense StereoBM over the full frame (11x11 windows, the extent of our W = 11, 64
// disparities) whose disparity would be read at the corners.
void BM_OpenCV_GFTT_plus_StereoBM(benchmark::State& state) {
  cv::setNumThreads(1);
  const BenchStereoPair& pair = benchStereoPair();
  const cv::Mat left = frontend::asMat(pair.left);
  const cv::Mat right = frontend::asMat(pair.right);
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(kBenchDisparities, 11);
  std::vector<cv::Point2f> corners;
  cv::Mat disparity;
  for (auto _ : state) {
    cv::goodFeaturesToTrack(left, corners, 1000, 0.01, 1.0, cv::noArray(), 3, 3, true, 0.04);
    bm->compute(left, right, disparity);
    benchmark::DoNotOptimize(corners.data());
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["corners"] = static_cast<double>(corners.size());
}
BENCHMARK(BM_OpenCV_GFTT_plus_StereoBM)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace twocam::bench
