#include "eval/landmark_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace twocam::eval {
namespace {

TEST(LandmarkMetrics, DistinctPointsMergeWithinTheRadiusOnly) {
  constexpr double kRadiusM = 0.02;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.005f, 0.005f);  // well inside the radius
  std::vector<Eigen::Vector3f> points;
  // Ten physical points 10 cm apart, each "confirmed" 1 to 4 times with a few mm of jitter.
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3f p(0.1f * static_cast<float>(i), 1.0f, 0.5f);
    for (int k = 0; k <= i % 4; ++k)
      points.push_back(p + Eigen::Vector3f(jitter(rng), jitter(rng), jitter(rng)));
  }
  EXPECT_EQ(countDistinctPoints(points, kRadiusM), 10);
  // Across a grid-cell boundary (x = 0.02 m) the neighbour cells are searched.
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(0.0199f, 0, 0), Eigen::Vector3f(0.0201f, 0, 0)},
                                kRadiusM),
            1);
  // Just beyond the radius: two points.
  EXPECT_EQ(
      countDistinctPoints({Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.0205f, 0, 0)}, kRadiusM), 2);
  EXPECT_EQ(countDistinctPoints({}, kRadiusM), 0);
  // Negative coordinates.
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(-0.001f, -5, -5), Eigen::Vector3f(0.001f, -5, -5)},
                                kRadiusM),
            1);
}

TEST(LandmarkMetrics, PatchStdDevIsTheGreyLevelSpreadOfTheClippedPatch) {
  constexpr double kTol = 1e-9;
  ImageU8 image(20, 10, 100);
  EXPECT_NEAR(patchStdDevGrey(image, 10, 5, kTexturePatchRadius), 0.0, kTol);  // plain
  // Columns alternating 90 (even) / 110 (odd): the 7x7 patch at (10, 5) spans columns 7..13,
  // four odd and three even.
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) image(u, v) = (u % 2) ? 110 : 90;
  }
  const double mean = (3.0 * 90 + 4.0 * 110) / 7.0;
  const double expected =
      std::sqrt((3.0 * (90 - mean) * (90 - mean) + 4.0 * (110 - mean) * (110 - mean)) / 7.0);
  EXPECT_NEAR(patchStdDevGrey(image, 10, 5, kTexturePatchRadius), expected, kTol);
  EXPECT_NEAR(
      patchStdDevGrey(image, 10.3, 4.8, kTexturePatchRadius), expected, kTol);  // nearest pixel
  // At the corner the patch is clipped to 4x4 (columns 0..3: two of each): std exactly 10.
  EXPECT_NEAR(patchStdDevGrey(image, 0, 0, kTexturePatchRadius), 10.0, kTol);
  // Outside the image: NaN, not a read out of bounds.
  EXPECT_TRUE(std::isnan(patchStdDevGrey(image, -1, 5, kTexturePatchRadius)));
  EXPECT_TRUE(std::isnan(patchStdDevGrey(image, 10, 10, kTexturePatchRadius)));
  EXPECT_TRUE(std::isnan(patchStdDevGrey(ImageU8(), 0, 0, kTexturePatchRadius)));
}

}  // namespace
}  // namespace twocam::eval
