#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

#include "frontend/ncc_scaled.h"
#include "frontend/ncc_test_support.h"

namespace twocam::frontend {
namespace {

// ---------------------------------------------------------------------------------------------
// Salient

TEST(MatchNccSalient, FindsTheTrueDisparityAtCornersWithAConsistentBest) {
  const Pair p = slantedPair(160, 40, 9.4, 0.0, 17);
  std::vector<Corner> corners;
  for (int u = 30; u < 156; u += 9) corners.push_back({u, 20, 1.0f});
  corners.push_back({1, 20, 1.0f});  // window does not fit: skipped
  StereoHypotheses hyps;
  std::vector<uint8_t> scales;
  NccScaledOptions o;
  o.max_disparity_px = 24;
  ASSERT_TRUE(matchNccSalient(p.left, p.right, corners, o, &hyps, &scales).isOk());
  ASSERT_EQ(hyps.points.size(), corners.size() - 1);
  EXPECT_EQ(scales.size(), hyps.hypotheses.size());
  size_t square = 0;
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const SalientPoint& pt = hyps.points[i];
    EXPECT_EQ(pt.corner.u_px, corners[i].u_px);
    ASSERT_GE(pt.num_hypotheses, 1u);
    const DisparityHypothesis& best = hyps.hypotheses[pt.first_hypothesis];
    EXPECT_EQ(best.rank, 0);
    EXPECT_EQ(best.point_index, i);
    // Within a pixel-locking margin where a scaled window won (see the fronto-parallel test).
    const double tol = scales[pt.first_hypothesis] == 1 ? kSubpixelTolPx : kScaledSubpixelTolPx;
    EXPECT_NEAR(best.d_px, 9.4, tol) << "corner " << pt.corner.u_px;
    square += scales[pt.first_hypothesis] == 1 ? 1 : 0;
    EXPECT_TRUE(best.lr_consistent);
    EXPECT_LE(best.cost, 0.1f) << "cost is 1 - NCC";
    for (uint32_t k = 1; k < pt.num_hypotheses; ++k) {
      EXPECT_GE(hyps.hypotheses[pt.first_hypothesis + k].cost,
                hyps.hypotheses[pt.first_hypothesis + k - 1].cost);
    }
  }
  EXPECT_GE(square, hyps.points.size() / 2) << "the square window wins at most corners";
}

TEST(MatchNccSalient, PeriodicTextureGivesOneHypothesisPerPeriod) {
  constexpr int kPeriod = 8;
  constexpr int kTrueD = 5;
  ImageU8 left(120, 30);
  ImageU8 right(120, 30);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> grey(20, 235);
  std::vector<int> tile(kPeriod);
  for (int& t : tile) t = grey(rng);
  for (int y = 0; y < 30; ++y) {
    for (int u = 0; u < 120; ++u) {
      left(u, y) = static_cast<uint8_t>(tile[u % kPeriod] + (y % 3) * 5);
      right(u, y) = static_cast<uint8_t>(tile[(u + kTrueD) % kPeriod] + (y % 3) * 5);
    }
  }
  NccScaledOptions o;
  o.max_disparity_px = 30;
  o.max_hypotheses = 8;
  o.scaled_windows = false;
  StereoHypotheses hyps;
  ASSERT_TRUE(matchNccSalient(left, right, {{60, 15, 1.0f}}, o, &hyps).isOk());
  ASSERT_EQ(hyps.points.size(), 1u);
  // Disparities 5, 13, 21, 29 all correlate perfectly.
  ASSERT_EQ(hyps.points[0].num_hypotheses, 4u);
  std::vector<float> ds;
  for (const DisparityHypothesis& h : hyps.hypotheses) ds.push_back(h.d_px);
  std::sort(ds.begin(), ds.end());
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(ds[k], kTrueD + k * kPeriod, kSubpixelTolPx);
  EXPECT_TRUE(hyps.points[0].complete);
  o.max_hypotheses = 2;
  ASSERT_TRUE(matchNccSalient(left, right, {{60, 15, 1.0f}}, o, &hyps).isOk());
  EXPECT_EQ(hyps.points[0].num_hypotheses, 2u);
  EXPECT_FALSE(hyps.points[0].complete) << "two aliases were dropped for want of room";
}

}  // namespace
}  // namespace twocam::frontend
