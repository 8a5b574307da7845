#include "eval/landmark_metrics.h"

#include <gtest/gtest.h>

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
    for (int k = 0; k <= i % 4; ++k) points.push_back(p + Eigen::Vector3f(jitter(rng), jitter(rng), jitter(rng)));
  }
  EXPECT_EQ(countDistinctPoints(points, kRadiusM), 10);
  // Across a grid-cell boundary (x = 0.02 m) the neighbour cells are searched.
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(0.0199f, 0, 0), Eigen::Vector3f(0.0201f, 0, 0)}, kRadiusM), 1);
  // Just beyond the radius: two points.
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.0205f, 0, 0)}, kRadiusM), 2);
  EXPECT_EQ(countDistinctPoints({}, kRadiusM), 0);
  // Negative coordinates.
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(-0.001f, -5, -5), Eigen::Vector3f(0.001f, -5, -5)}, kRadiusM), 1);
}

}  // namespace
}  // namespace twocam::eval
