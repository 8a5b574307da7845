#include "frontend/sad_kernels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "frontend/cv_interop.h"
#include "frontend/salient_sad.h"
#include "frontend/salient_test_support.h"

namespace twocam::frontend {
namespace {

TEST(SamplingIntervals, SpanEachPixelAndItsHalfPixelNeighbours) {
  ImageU8 image;
  image.width = 5;
  image.height = 2;
  image.data = {10,
                20,
                200,
                200,
                0,  //
                7,
                7,
                7,
                7,
                7};
  ImageU8 lo;
  ImageU8 hi;
  internal::samplingIntervals(image, &lo, &hi);
  ASSERT_EQ(lo.width, 5);
  ASSERT_EQ(hi.height, 2);
  // Half-pixel values of row 0: 15, 110, 200, 100 (rounded half up).
  EXPECT_EQ(lo.data, (std::vector<uint8_t>{10, 15, 110, 100, 0, 7, 7, 7, 7, 7}));
  EXPECT_EQ(hi.data, (std::vector<uint8_t>{15, 110, 200, 200, 100, 7, 7, 7, 7, 7}));
}

// ---------------------------------------------------------------------------------------------
// Kernels: every SIMD path must equal the scalar one bit for bit.

std::vector<Simd> availableKernels() {
  std::vector<Simd> kernels;
  for (Simd k : {Simd::kScalar, Simd::kSse2, Simd::kAvx2}) {
    if (simdAvailable(k)) kernels.push_back(k);
  }
  return kernels;
}

TEST(SadKernels, CostCurvesBitIdenticalToScalar) {
  std::printf("[ kernels ] available:");
  for (Simd k : availableKernels()) std::printf(" %d", static_cast<int>(k));
  std::printf(" (1 scalar, 2 SSE2, 3 AVX2); auto = %d\n",
              static_cast<int>(resolveSimd(Simd::kAuto)));
  std::mt19937 rng(91);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> half_width(0, 31);
  std::uniform_int_distribution<int> length(1, 256);
  std::uniform_int_distribution<int> extreme(0, 3);
  constexpr int kTrials = 1000;
  std::vector<uint8_t> win(64);
  std::vector<uint8_t> strip(256 + 64);
  std::vector<int16_t> offsets(256);
  std::vector<uint16_t> reference(256);
  std::vector<uint16_t> cost(256);
  for (int trial = 0; trial < kTrials; ++trial) {
    const int w = 2 * half_width(rng) + 1;
    const int n = length(rng);
    // Some trials use only 0 and 255 to reach the largest sums.
    const bool saturate = extreme(rng) == 0;
    for (uint8_t& b : win) b = static_cast<uint8_t>(saturate ? (byte(rng) & 1) * 255 : byte(rng));
    for (uint8_t& b : strip) {
      b = static_cast<uint8_t>(saturate ? (byte(rng) & 1) * 255 : byte(rng));
    }
    const bool zero_mean = trial % 2 == 1;
    for (int16_t& o : offsets) o = static_cast<int16_t>(byte(rng) * 2 - 255);
    const int16_t* off = zero_mean ? offsets.data() : nullptr;
    internal::sadCurve(Simd::kScalar, win.data(), w, strip.data(), off, n, reference.data());
    for (Simd k : availableKernels()) {
      std::fill(cost.begin(), cost.end(), uint16_t{0xFFFF});
      internal::sadCurve(k, win.data(), w, strip.data(), off, n, cost.data());
      for (int j = 0; j < n; ++j) {
        ASSERT_EQ(cost[j], reference[j]) << "kernel " << static_cast<int>(k) << " trial " << trial
                                         << " w " << w << " n " << n << " j " << j;
      }
    }
    // Spot-check the scalar reference itself against the definition.
    const int j = n - 1;
    int expected = 0;
    for (int i = 0; i < w; ++i) {
      expected += std::abs(win[i] - strip[i + j] + (zero_mean ? offsets[j] : 0));
    }
    ASSERT_EQ(reference[j], expected);
  }
}

TEST(SadKernels, PrefixCurvesEqualDirectWindows) {
  // The fused shiftable-window pass: prefixes over 2W-1 offsets, differences of prefixes must
  // equal the three W-wide windows computed directly, on every kernel.
  std::mt19937 rng(95);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> half_width(1, 31);
  std::uniform_int_distribution<int> length(1, 256);
  constexpr int kTrials = 300;
  std::vector<uint8_t> win(128);
  std::vector<uint8_t> strip(256 + 128);
  std::vector<std::vector<uint16_t>> prefix(5, std::vector<uint16_t>(256));
  std::vector<uint16_t> direct(256);
  for (int trial = 0; trial < kTrials; ++trial) {
    const int h = half_width(rng);
    const int w = 2 * h + 1;
    const int n = length(rng);
    for (uint8_t& b : win) b = static_cast<uint8_t>(byte(rng));
    for (uint8_t& b : strip) b = static_cast<uint8_t>(byte(rng));
    const int ends[5] = {h, 2 * h, 2 * h + 1, 3 * h + 1, 4 * h + 1};
    for (Simd k : availableKernels()) {
      uint16_t* const outs[5] = {
          prefix[0].data(), prefix[1].data(), prefix[2].data(), prefix[3].data(), prefix[4].data()};
      internal::sadPrefixCurves(k, win.data(), strip.data(), n, ends, 5, outs);
      for (int a = 0; a < 3; ++a) {  // window starting at offset 0, h, 2h
        internal::sadCurve(
            Simd::kScalar, win.data() + a * h, w, strip.data() + a * h, nullptr, n, direct.data());
        for (int j = 0; j < n; ++j) {
          const int from_prefix =
              a == 0 ? prefix[2][j]
                     : (a == 1 ? prefix[3][j] - prefix[0][j] : prefix[4][j] - prefix[1][j]);
          ASSERT_EQ(from_prefix, direct[j]) << "kernel " << static_cast<int>(k) << " trial "
                                            << trial << " alignment " << a << " j " << j;
        }
      }
    }
  }
}

TEST(SadKernels, IntervalCurvesBitIdenticalToScalarAndTheirDefinition) {
  // Birchfield-Tomasi prefix curves: the distance of each window pixel to the strip's interval
  // [lo, hi], on every kernel, including intervals reaching 0 and 255; with lo == hi they are
  // plain SAD. The same for the zero-mean curves (window pixel + offset).
  std::mt19937 rng(97);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> half_width(1, 31);
  std::uniform_int_distribution<int> length(1, 256);
  constexpr int kTrials = 300;
  std::vector<uint8_t> win(128);
  std::vector<uint8_t> lo(256 + 128);
  std::vector<uint8_t> hi(256 + 128);
  std::vector<std::vector<uint16_t>> reference(3, std::vector<uint16_t>(256));
  std::vector<std::vector<uint16_t>> out(3, std::vector<uint16_t>(256));
  std::vector<uint16_t> sad(256);
  std::vector<int16_t> offsets(256);
  for (int trial = 0; trial < kTrials; ++trial) {
    const int h = half_width(rng);
    const int n = length(rng);
    for (uint8_t& b : win) b = static_cast<uint8_t>(byte(rng));
    for (size_t i = 0; i < lo.size(); ++i) {
      const int a = byte(rng);
      const int b = byte(rng);
      lo[i] = static_cast<uint8_t>(std::min(a, b));
      hi[i] = static_cast<uint8_t>(std::max(a, b));
    }
    const int ends[3] = {h, 2 * h + 1, 4 * h + 1};
    uint16_t* const ref_outs[3] = {reference[0].data(), reference[1].data(), reference[2].data()};
    internal::intervalPrefixCurves(
        Simd::kScalar, win.data(), lo.data(), hi.data(), n, ends, 3, ref_outs);
    for (int e = 0; e < 3; ++e) {
      const int j = trial % n;
      int expected = 0;
      for (int i = 0; i < ends[e]; ++i) {
        expected += std::max({0, lo[i + j] - win[i], win[i] - hi[i + j]});
      }
      ASSERT_EQ(reference[e][j], expected) << "trial " << trial << " end " << ends[e];
    }
    for (Simd k : availableKernels()) {
      uint16_t* const outs[3] = {out[0].data(), out[1].data(), out[2].data()};
      internal::intervalPrefixCurves(k, win.data(), lo.data(), hi.data(), n, ends, 3, outs);
      for (int e = 0; e < 3; ++e) {
        for (int j = 0; j < n; ++j) {
          ASSERT_EQ(out[e][j], reference[e][j]) << "kernel " << static_cast<int>(k) << " trial "
                                                << trial << " end " << e << " j " << j;
        }
      }
      // A zero-width interval is plain SAD.
      internal::intervalPrefixCurves(k, win.data(), lo.data(), lo.data(), n, ends, 3, outs);
      internal::sadCurve(k, win.data(), ends[2], lo.data(), nullptr, n, sad.data());
      for (int j = 0; j < n; ++j) ASSERT_EQ(out[2][j], sad[j]) << "kernel " << static_cast<int>(k);
    }
    // Zero-mean: the distance of win[i] + offsets[j] to the interval, on every kernel.
    const int w = 2 * h + 1;
    for (int16_t& o : offsets) o = static_cast<int16_t>(byte(rng) * 2 - 255);
    internal::intervalCurve(
        Simd::kScalar, win.data(), w, lo.data(), hi.data(), offsets.data(), n, reference[0].data());
    const int j = (trial * 7) % n;
    int expected = 0;
    for (int i = 0; i < w; ++i) {
      const int x = win[i] + offsets[j];
      expected += std::max({0, lo[i + j] - x, x - hi[i + j]});
    }
    ASSERT_EQ(reference[0][j], expected) << "zero-mean, trial " << trial;
    for (Simd k : availableKernels()) {
      std::fill(out[0].begin(), out[0].end(), uint16_t{0xFFFF});
      internal::intervalCurve(
          k, win.data(), w, lo.data(), hi.data(), offsets.data(), n, out[0].data());
      for (int jj = 0; jj < n; ++jj) {
        ASSERT_EQ(out[0][jj], reference[0][jj])
            << "zero-mean, kernel " << static_cast<int>(k) << " trial " << trial << " j " << jj;
      }
      // A zero-width interval is zero-mean SAD.
      internal::intervalCurve(
          k, win.data(), w, lo.data(), lo.data(), offsets.data(), n, out[1].data());
      internal::sadCurve(k, win.data(), w, lo.data(), offsets.data(), n, sad.data());
      for (int jj = 0; jj < n; ++jj)
        ASSERT_EQ(out[1][jj], sad[jj]) << "kernel " << static_cast<int>(k);
    }
  }
}

bool sameHypotheses(const StereoHypotheses& a, const StereoHypotheses& b) {
  if (a.points.size() != b.points.size() || a.hypotheses.size() != b.hypotheses.size()) {
    return false;
  }
  for (size_t i = 0; i < a.points.size(); ++i) {
    if (a.points[i].first_hypothesis != b.points[i].first_hypothesis ||
        a.points[i].num_hypotheses != b.points[i].num_hypotheses) {
      return false;
    }
  }
  for (size_t i = 0; i < a.hypotheses.size(); ++i) {
    const DisparityHypothesis& x = a.hypotheses[i];
    const DisparityHypothesis& y = b.hypotheses[i];
    if (x.d_px != y.d_px || x.cost != y.cost || x.point_index != y.point_index ||
        x.row_offset_px != y.row_offset_px || x.rank != y.rank ||
        x.lr_consistent != y.lr_consistent) {
      return false;
    }
  }
  return true;
}

TEST(SadKernels, MatcherOutputIdenticalAcrossKernels) {
  const cv::Mat tex = randomTexture(400, 140, 101);
  StereoPair pair = shiftedPair(tex, 320, 120, 13);
  std::mt19937 rng(102);
  std::normal_distribution<double> noise(0.0, 3.0);
  for (uint8_t& px : pair.right.data) px = cv::saturate_cast<uint8_t>(px + noise(rng));
  // Corners everywhere, including the last rows (padded reads near the buffer's end).
  const std::vector<Corner> corners = gridCorners(0, 320, 0, 120, 3);
  for (int cost : {0, 1, 2, 3}) {  // plain SAD, zero-mean, Birchfield-Tomasi, both
    const bool zero_mean = cost % 2 == 1;
    for (int m : {0, 2}) {
      SalientSadOptions options;
      options.zero_mean = zero_mean;
      options.birchfield_tomasi = cost >= 2;
      options.row_tolerance_px = m;
      options.max_disparity_px = 40;  // 41 disparities: a partial last vector
      options.simd = Simd::kScalar;
      StereoHypotheses reference;
      ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &reference).isOk());
      ASSERT_FALSE(reference.hypotheses.empty());
      for (Simd k : availableKernels()) {
        options.simd = k;
        StereoHypotheses out;
        ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &out).isOk());
        EXPECT_TRUE(sameHypotheses(reference, out))
            << "kernel " << static_cast<int>(k) << " cost " << cost << " m " << m;
      }
    }
  }
}

}  // namespace
}  // namespace twocam::frontend
