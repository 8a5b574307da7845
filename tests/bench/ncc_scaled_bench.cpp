// Scaled-window NCC (frontend/ncc_scaled.h) against 1-D SAD (dense_sad.h, salient_sad.h) and
// OpenCV's StereoBM / StereoSGBM on Middlebury Tsukuba (384x288, 16 disparities, the figures of
// docs/frontend.md), single thread, in one binary so the timings share the machine's load.
// The pair is read from ../shared/data (next to the working folder, or found from the binary's
// path); without it every benchmark here reports an error instead of a time. Run:
//   taskset -c 1 build/release/tests/bench/frontend_bench --benchmark_filter='Tsukuba'
//       --benchmark_repetitions=5 --benchmark_report_aggregates_only=true   (one command line)
// Counter s_per_MP: seconds per megapixel, as the papers report speed.

#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"
#include "frontend/ncc_scaled.h"
#include "frontend/salient_sad.h"

namespace twocam::bench {
namespace {

constexpr int kTsukubaMaxDisparity = 16;  // docs/frontend.md's stereo-eval --max-disp
constexpr int kTsukubaCorners = 360;      // 1000 per 640x480, as stereo-eval's salient mode

struct TsukubaPair {
  ImageU8 left;
  ImageU8 right;
};

std::optional<std::string> findTsukuba() {
  namespace fs = std::filesystem;
  std::vector<fs::path> roots = {fs::current_path() / ".." / "shared" / "data"};
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    // build/<dir>/tests/bench/frontend_bench -> project root -> ../shared/data
    roots.push_back(exe.parent_path() / ".." / ".." / ".." / ".." / ".." / "shared" / "data");
  }
  for (const fs::path& root : roots) {
    const fs::path dir = root / "middlebury" / "tsukuba";
    if (fs::is_regular_file(dir / "im3.png", ec)) return dir.string();
  }
  return std::nullopt;
}

/// Loaded once, outside every timed loop; nullptr when the shared data is absent.
const TsukubaPair* tsukuba() {
  static const std::optional<TsukubaPair> kPair = []() -> std::optional<TsukubaPair> {
    const std::optional<std::string> dir = findTsukuba();
    if (!dir) return std::nullopt;
    TsukubaPair p;
    if (!frontend::loadGrey(*dir + "/im3.png", &p.left).isOk() ||
        !frontend::loadGrey(*dir + "/im4.png", &p.right).isOk()) {
      return std::nullopt;
    }
    return p;
  }();
  return kPair ? &*kPair : nullptr;
}

void setRates(benchmark::State& state, const ImageU8& image) {
  const double mp = static_cast<double>(image.width) * image.height * 1e-6;
  state.counters["s_per_MP"] = benchmark::Counter(
      mp, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

/// Arg: 0 paper's defaults (3 scales, sub-pixel, median rejection, bilateral); 1 matching and
/// sub-pixel only (no filters); 2 integer matching only; 3 integer matching, square window only.
void BM_Tsukuba_NccScaledDense(benchmark::State& state) {
  const TsukubaPair* pair = tsukuba();
  if (pair == nullptr) {
    state.SkipWithError("../shared/data/middlebury/tsukuba not found");
    return;
  }
  frontend::NccScaledOptions o;
  o.max_disparity_px = kTsukubaMaxDisparity;
  const int64_t variant = state.range(0);
  if (variant >= 1) o.median_rejection = o.bilateral = false;
  if (variant >= 2) o.subpixel_steps = 0;
  if (variant >= 3) o.scaled_windows = false;
  frontend::NccScaledMatcher matcher;
  ImageF32 disparity;
  for (auto _ : state) {
    const Status s = matcher.compute(pair->left, pair->right, o, &disparity);
    if (!s) state.SkipWithError(s.message().c_str());
    benchmark::DoNotOptimize(disparity.data.data());
    benchmark::ClobberMemory();
  }
  setRates(state, pair->left);
}
BENCHMARK(BM_Tsukuba_NccScaledDense)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

/// Arg: 0 the dense SAD defaults (lrc,prop,median), 1 the same with its sub-pixel fit.
void BM_Tsukuba_DenseSad(benchmark::State& state) {
  const TsukubaPair* pair = tsukuba();
  if (pair == nullptr) {
    state.SkipWithError("../shared/data/middlebury/tsukuba not found");
    return;
  }
  frontend::DenseSadOptions o;
  o.max_disparity_px = kTsukubaMaxDisparity;
  o.subpixel = state.range(0) != 0;
  frontend::DenseSadMatcher matcher;
  ImageF32 disparity;
  for (auto _ : state) {
    const Status s = matcher.compute(pair->left, pair->right, o, &disparity);
    if (!s) state.SkipWithError(s.message().c_str());
    benchmark::DoNotOptimize(disparity.data.data());
    benchmark::ClobberMemory();
  }
  setRates(state, pair->left);
}
BENCHMARK(BM_Tsukuba_DenseSad)->DenseRange(0, 1)->Unit(benchmark::kMillisecond);

void BM_Tsukuba_CvStereoBM(benchmark::State& state) {
  cv::setNumThreads(1);
  const TsukubaPair* pair = tsukuba();
  if (pair == nullptr) {
    state.SkipWithError("../shared/data/middlebury/tsukuba not found");
    return;
  }
  // numDisparities must be a multiple of 16: 16 covers 0..15 (Tsukuba's truth reaches 14).
  cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(16, 7);
  cv::Mat disparity;
  const cv::Mat left = frontend::asMat(pair->left);
  const cv::Mat right = frontend::asMat(pair->right);
  for (auto _ : state) {
    bm->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  setRates(state, pair->left);
}
BENCHMARK(BM_Tsukuba_CvStereoBM)->Unit(benchmark::kMillisecond);

void BM_Tsukuba_CvStereoSGBM(benchmark::State& state) {
  cv::setNumThreads(1);
  const TsukubaPair* pair = tsukuba();
  if (pair == nullptr) {
    state.SkipWithError("../shared/data/middlebury/tsukuba not found");
    return;
  }
  constexpr int kBlock = 5;  // OpenCV's documented starting point, as dense_bench.cpp
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0,
                                                        16,
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
  const cv::Mat left = frontend::asMat(pair->left);
  const cv::Mat right = frontend::asMat(pair->right);
  for (auto _ : state) {
    sgbm->compute(left, right, disparity);
    benchmark::DoNotOptimize(disparity.data);
    benchmark::ClobberMemory();
  }
  setRates(state, pair->left);
}
BENCHMARK(BM_Tsukuba_CvStereoSGBM)->Unit(benchmark::kMillisecond);

std::vector<Corner> tsukubaCorners(const ImageU8& image) {
  std::vector<cv::Point2f> pts;
  cv::goodFeaturesToTrack(
      frontend::asMat(image), pts, kTsukubaCorners, 1e-4, 2.0, cv::noArray(), 3, true);
  std::vector<Corner> corners;
  for (const cv::Point2f& p : pts) {
    corners.push_back(
        {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y)), 1.0f});
  }
  return corners;
}

void BM_Tsukuba_NccScaledSalient(benchmark::State& state) {
  cv::setNumThreads(1);
  const TsukubaPair* pair = tsukuba();
  if (pair == nullptr) {
    state.SkipWithError("../shared/data/middlebury/tsukuba not found");
    return;
  }
  const std::vector<Corner> corners = tsukubaCorners(pair->left);
  frontend::NccScaledOptions o;
  o.max_disparity_px = kTsukubaMaxDisparity;
  StereoHypotheses out;
  for (auto _ : state) {
    const Status s = frontend::matchNccSalient(pair->left, pair->right, corners, o, &out);
    if (!s) state.SkipWithError(s.message().c_str());
    benchmark::DoNotOptimize(out.hypotheses.data());
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  state.counters["us_per_corner"] = benchmark::Counter(
      static_cast<double>(corners.size()) * 1e-6,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_Tsukuba_NccScaledSalient)->Unit(benchmark::kMicrosecond);

void BM_Tsukuba_SalientSad(benchmark::State& state) {
  cv::setNumThreads(1);
  const TsukubaPair* pair = tsukuba();
  if (pair == nullptr) {
    state.SkipWithError("../shared/data/middlebury/tsukuba not found");
    return;
  }
  const std::vector<Corner> corners = tsukubaCorners(pair->left);
  frontend::SalientSadOptions o;
  o.max_disparity_px = kTsukubaMaxDisparity;
  StereoHypotheses out;
  for (auto _ : state) {
    const Status s = frontend::matchSalient(pair->left, pair->right, corners, o, &out);
    if (!s) state.SkipWithError(s.message().c_str());
    benchmark::DoNotOptimize(out.hypotheses.data());
  }
  state.counters["corners"] = static_cast<double>(corners.size());
  state.counters["us_per_corner"] = benchmark::Counter(
      static_cast<double>(corners.size()) * 1e-6,
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_Tsukuba_SalientSad)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace twocam::bench
