#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <vector>

#include "frontend/support_value_internal.h"

// The support-value matcher's geometry, weights, padded images, window sums and hot loops
// (support_value_kernels.cpp) against brute-force sums over the windows, for the baseline
// kernels and the ones this CPU runs (AVX2 + POPCNT where there is AVX2).

namespace twocam::frontend::internal::support {
namespace {

/// fastCorrelation works in float from per-pixel 1/std; correlation in double from the sums.
constexpr float kCorrelationTol = 1e-5f;

ImageU8 randomImage(uint32_t seed, int width, int height) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> grey(0, 255);
  ImageU8 image(width, height);
  for (uint8_t& px : image.data) px = static_cast<uint8_t>(grey(rng));
  return image;
}

/// Brute force: bit i * win + j set when the padded pixel (x + j, y + i) exceeds the window
/// mean rounded down.
std::vector<uint64_t> bruteStructure(const std::vector<uint8_t>& pad,
                                     const Geometry& g,
                                     int x,
                                     int y) {
  int64_t sum = 0;
  for (int i = 0; i < g.win; ++i) {
    for (int j = 0; j < g.win; ++j) sum += pad[static_cast<size_t>(y + i) * g.wp + x + j];
  }
  const int64_t threshold = sum / g.n;
  std::vector<uint64_t> bits(static_cast<size_t>(g.words), 0);
  for (int i = 0; i < g.win; ++i) {
    for (int j = 0; j < g.win; ++j) {
      const int k = i * g.win + j;
      if (pad[static_cast<size_t>(y + i) * g.wp + x + j] > threshold) {
        bits[static_cast<size_t>(k / 64)] |= uint64_t{1} << (k % 64);
      }
    }
  }
  return bits;
}

/// Brute force: sum of the weights where the two structures agree.
int64_t bruteSupport(const uint64_t* a, const uint64_t* b, const std::vector<int>& weights) {
  int64_t s = 0;
  for (size_t k = 0; k < weights.size(); ++k) {
    const bool bit_a = ((a[k / 64] >> (k % 64)) & 1) != 0;
    const bool bit_b = ((b[k / 64] >> (k % 64)) & 1) != 0;
    s += bit_a == bit_b ? weights[k] : 0;
  }
  return s;
}

/// What pixelStats stores for a window with these sums (variance > 0).
PixelStats statsOf(const WindowStats& w, int n) {
  const double var = static_cast<double>(n * w.sq - w.sum * w.sum);
  return {static_cast<int32_t>(w.sum), static_cast<float>(1.0 / std::sqrt(var))};
}

TEST(SupportValueKernels, GeometryAndWeightPlanes) {
  SupportValueOptions o;
  o.window_px = 13;
  o.min_disparity_px = 2;
  o.max_disparity_px = 20;
  const Geometry g = makeGeometry(100, 40, o);
  EXPECT_EQ(g.half, 6);
  EXPECT_EQ(g.n, 169);
  EXPECT_EQ(g.words, 3);
  EXPECT_EQ(g.wp, 112);
  EXPECT_EQ(g.hp, 52);
  EXPECT_EQ(g.nd, 19);
  const WeightPlanes equal = makePlanes(o);
  EXPECT_TRUE(equal.equal);
  EXPECT_EQ(equal.total, 169);
  // Decreasing 3 x 3: centre 2, ring 1: planes 0 (the ring) and 1 (the centre).
  o.window_px = 3;
  o.weighting = SupportWeighting::kDecreasing;
  const WeightPlanes decreasing = makePlanes(o);
  EXPECT_FALSE(decreasing.equal);
  EXPECT_EQ(decreasing.total, 10);
  ASSERT_EQ(decreasing.count, 2);
  EXPECT_EQ(decreasing.mask[0][0], uint64_t{0x1EF});  // all but bit 4
  EXPECT_EQ(decreasing.mask[1][0], uint64_t{0x10});
}

TEST(SupportValueKernels, PaddingRepeatsTheEdgesAndSumsMatchTheWindows) {
  const ImageU8 image = randomImage(5, 23, 11);
  SupportValueOptions o;
  o.window_px = 7;
  o.max_disparity_px = 8;
  const Geometry g = makeGeometry(image.width, image.height, o);
  std::vector<uint8_t> pad;
  padImage(image, g, &pad);
  ASSERT_GE(pad.size(), static_cast<size_t>(g.wp) * g.hp);
  for (int y = 0; y < g.hp; ++y) {
    for (int x = 0; x < g.wp; ++x) {
      const int u = std::clamp(x - g.half, 0, image.width - 1);
      const int v = std::clamp(y - g.half, 0, image.height - 1);
      ASSERT_EQ(pad[static_cast<size_t>(y) * g.wp + x], image(u, v)) << x << ", " << y;
    }
  }
  std::vector<int64_t> sum, sq;
  integrate(pad, g, &sum, &sq);
  std::vector<PixelStats> stats;
  pixelStats(sum, sq, g, &stats);
  ASSERT_EQ(stats.size(), image.data.size());
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) {
      const WindowStats direct = directStats(pad, g, u, v);
      EXPECT_EQ(stats[static_cast<size_t>(v) * g.width + u].sum, direct.sum);
    }
  }
  // Correlations from the per-pixel stats agree with the exact ones; a window with itself is 1.
  const ImageU8 other = randomImage(6, 23, 11);
  std::vector<uint8_t> other_pad;
  padImage(other, g, &other_pad);
  for (int u = 0; u < image.width; u += 3) {
    const WindowStats l = directStats(pad, g, u, 5);
    const WindowStats r = directStats(other_pad, g, u, 5);
    const int64_t cross = crossSum(pad.data(), other_pad.data(), g, u, u, 5);
    const float exact = correlation(cross, l, r, g.n);
    const PixelStats pl = statsOf(l, g.n);
    const PixelStats pr = statsOf(r, g.n);
    EXPECT_NEAR(fastCorrelation(static_cast<int32_t>(cross), pl, pr, g.n), exact, kCorrelationTol);
    const int64_t self = crossSum(pad.data(), pad.data(), g, u, u, 5);
    EXPECT_NEAR(correlation(self, l, l, g.n), 1.0f, kCorrelationTol);
  }
  // No variance: no correlation.
  const WindowStats flat{static_cast<int64_t>(g.n) * 7, static_cast<int64_t>(g.n) * 49};
  EXPECT_EQ(correlation(flat.sum * 7, flat, flat, g.n), kNoCorrelation);
}

TEST(SupportValueKernels, EveryKernelMatchesTheBruteForceSums) {
  const ImageU8 left = randomImage(7, 37, 14);
  const ImageU8 right = randomImage(8, 37, 14);
  for (const int window : {5, 9, 15, 17}) {  // 1, 2, 4 and 5 (generic loop) words
    for (const SupportWeighting weighting :
         {SupportWeighting::kEqual, SupportWeighting::kDecreasing}) {
      SupportValueOptions o;
      o.window_px = window;
      o.weighting = weighting;
      o.min_disparity_px = 1;
      o.max_disparity_px = 12;
      const Geometry g = makeGeometry(left.width, left.height, o);
      const WeightPlanes planes = makePlanes(o);
      std::vector<int> weights(static_cast<size_t>(g.n), 1);
      if (weighting == SupportWeighting::kDecreasing) {
        for (int i = 0; i < g.win; ++i) {
          for (int j = 0; j < g.win; ++j) {
            const int ring = std::max(std::abs(i - g.half), std::abs(j - g.half));
            weights[static_cast<size_t>(i) * g.win + j] = g.half + 1 - ring;
          }
        }
      }
      std::vector<uint8_t> lpad, rpad;
      padImage(left, g, &lpad);
      padImage(right, g, &rpad);
      std::vector<int64_t> lsum, lsq, rsum, rsq;
      integrate(lpad, g, &lsum, &lsq);
      integrate(rpad, g, &rsum, &rsq);
      const size_t pixels = left.data.size();
      const size_t words = static_cast<size_t>(g.words);
      for (const Simd simd : {Simd::kScalar, Simd::kAuto}) {
        SCOPED_TRACE(::testing::Message()
                     << "window " << window << ", weighting " << static_cast<int>(weighting)
                     << ", simd " << static_cast<int>(simd));
        const Kernels k = kernelsFor(simd);
        std::vector<uint64_t> lmasks(pixels * words), rmasks(pixels * words);
        k.structures(lpad.data(), lsum, g, lmasks.data());
        k.structures(rpad.data(), rsum, g, rmasks.data());
        for (int v = 0; v < g.height; ++v) {
          for (int u = 0; u < g.width; ++u) {
            const size_t at = (static_cast<size_t>(v) * g.width + u) * words;
            const std::vector<uint64_t> brute = bruteStructure(lpad, g, u, v);
            ASSERT_EQ(std::vector<uint64_t>(lmasks.begin() + at, lmasks.begin() + at + words),
                      brute)
                << u << ", " << v;
            std::vector<uint64_t> one(words);
            k.structure(lpad.data(), g, u, v, directStats(lpad, g, u, v).sum, one.data());
            ASSERT_EQ(one, brute);
          }
        }
        std::vector<int32_t> sv(static_cast<size_t>(g.width) * g.nd);
        std::vector<int32_t> col(static_cast<size_t>(g.wp) * g.nd, 0);
        std::vector<int32_t> cross(static_cast<size_t>(g.width) * g.nd, 0);
        for (int v = 0; v < g.height; ++v) {
          const size_t row = static_cast<size_t>(v) * g.width * words;
          k.support(lmasks.data() + row, rmasks.data() + row, g, planes, sv.data());
          k.cross(lpad.data(), rpad.data(), g, v, col.data(), cross.data());
          for (int u = 0; u < g.width; ++u) {
            for (int dk = 0; dk < g.nd; ++dk) {
              const int d = g.dmin + dk;
              const int32_t got = sv[static_cast<size_t>(u) * g.nd + dk];
              if (u - d < 0) {
                ASSERT_EQ(got, kNoMatch);
                continue;
              }
              const uint64_t* a = lmasks.data() + row + static_cast<size_t>(u) * words;
              const uint64_t* b = rmasks.data() + row + static_cast<size_t>(u - d) * words;
              ASSERT_EQ(got, bruteSupport(a, b, weights)) << u << ", " << v << ", d " << d;
              ASSERT_EQ(planes.total - k.disagreement(a, b, g.words, planes), got);
              ASSERT_EQ(cross[static_cast<size_t>(dk) * g.width + u],
                        crossSum(lpad.data(), rpad.data(), g, u, u - d, v))
                  << u << ", " << v << ", d " << d;
            }
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace twocam::frontend::internal::support
