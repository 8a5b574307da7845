#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "frontend/dense_sad.h"
#include "frontend/ncc_scaled.h"

namespace twocam::frontend {
namespace {

// ---------------------------------------------------------------------------------------------
// Filters

TEST(MedianRejectDisparity, RejectsValuesFarFromTheirWindowMedian) {
  ImageF32 d(9, 9, 5.0f);
  d(4, 4) = 9.0f;   // 4 px off: rejected
  d(2, 2) = 6.5f;   // 1.5 px off: kept
  d(6, 6) = -1.0f;  // no estimate stays none
  ASSERT_TRUE(medianRejectDisparity(5, 2.0f, 10, &d).isOk());
  EXPECT_EQ(d(4, 4), kNoDisparity);
  EXPECT_EQ(d(2, 2), 6.5f);
  EXPECT_EQ(d(6, 6), -1.0f);
  EXPECT_EQ(d(0, 0), 5.0f);
  EXPECT_EQ(d(8, 8), 5.0f);
}

TEST(MedianRejectDisparity, MatchesABruteForceMedianOnARandomGridMap) {
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> code(-8, 60);  // negative: no estimate
  ImageF32 d(23, 17);
  for (float& x : d.data) {
    const int c = code(rng);
    x = c < 0 ? kNoDisparity : static_cast<float>(c) / 10.0f;
  }
  ImageF32 expected = d;
  for (int v = 0; v < d.height; ++v) {
    for (int u = 0; u < d.width; ++u) {
      if (d(u, v) < 0.0f) continue;
      std::vector<float> values;
      for (int y = std::max(0, v - 3); y <= std::min(d.height - 1, v + 3); ++y) {
        for (int x = std::max(0, u - 3); x <= std::min(d.width - 1, u + 3); ++x) {
          if (d(x, y) >= 0.0f) values.push_back(d(x, y));
        }
      }
      std::sort(values.begin(), values.end());
      const float median = values[(values.size() - 1) / 2];
      if (std::abs(d(u, v) - median) > 1.5f) expected(u, v) = kNoDisparity;
    }
  }
  ASSERT_TRUE(medianRejectDisparity(7, 1.5f, 10, &d).isOk());
  EXPECT_EQ(d.data, expected.data);
}

TEST(MedianRejectDisparity, BadArgumentsAreErrors) {
  ImageF32 d(5, 5, 3.0f);
  EXPECT_FALSE(medianRejectDisparity(4, 2.0f, 10, &d).isOk());
  EXPECT_FALSE(medianRejectDisparity(5, 0.0f, 10, &d).isOk());
  EXPECT_FALSE(medianRejectDisparity(5, 2.0f, 0, &d).isOk());
  EXPECT_FALSE(medianRejectDisparity(5, 2.0f, 10, nullptr).isOk());
  ImageF32 huge(3, 3, 1e6f);
  EXPECT_FALSE(medianRejectDisparity(3, 2.0f, 10, &huge).isOk());
  EXPECT_EQ(d.data, std::vector<float>(25, 3.0f));
}

TEST(NccBilateralFilter, WeighsNeighboursByTheirNcc) {
  ImageF32 d(7, 7, 4.0f);
  ImageF32 ncc(7, 7, 1.0f);
  d(3, 3) = 4.5f;
  ImageF32 trusted = d;
  ASSERT_TRUE(nccBilateralFilter(ncc, 7, 2.0f, 1.0f, &trusted).isOk());
  EXPECT_LT(trusted(3, 3), 4.2f) << "pulled towards its confident neighbours";
  EXPECT_GT(trusted(3, 3), 4.0f);
  // The same neighbours with NCC 0 have no say: the centre keeps its value.
  ImageF32 doubted_ncc(7, 7, 0.0f);
  doubted_ncc(3, 3) = 0.9f;
  ImageF32 doubted = d;
  ASSERT_TRUE(nccBilateralFilter(doubted_ncc, 7, 2.0f, 1.0f, &doubted).isOk());
  EXPECT_FLOAT_EQ(doubted(3, 3), 4.5f);
  // A step far beyond the range sigma is kept sharp; holes stay holes.
  ImageF32 step(8, 4, 2.0f);
  for (int v = 0; v < 4; ++v) {
    for (int u = 4; u < 8; ++u) step(u, v) = 12.0f;
  }
  step(0, 0) = kNoDisparity;
  ASSERT_TRUE(nccBilateralFilter(ImageF32(8, 4, 1.0f), 5, 3.0f, 1.0f, &step).isOk());
  EXPECT_NEAR(step(3, 1), 2.0f, 1e-5f);
  EXPECT_NEAR(step(4, 1), 12.0f, 1e-5f);
  EXPECT_EQ(step(0, 0), kNoDisparity);
  EXPECT_FALSE(nccBilateralFilter(ImageF32(3, 3), 5, 3.0f, 1.0f, &step).isOk());
  EXPECT_FALSE(nccBilateralFilter(ImageF32(8, 4), 4, 3.0f, 1.0f, &step).isOk());
  EXPECT_FALSE(nccBilateralFilter(ImageF32(8, 4), 5, 0.0f, 1.0f, &step).isOk());
}

}  // namespace
}  // namespace twocam::frontend
