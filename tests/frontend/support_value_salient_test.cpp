#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "frontend/support_value.h"
#include "frontend/support_value_test_support.h"

namespace twocam::frontend {
namespace {

/// Disparities are whole pixels.
constexpr float kExactTol = 0.0f;

// ---------------------------------------------------------------------------------------------
// Salient matcher.

std::vector<Corner> gridCorners(int width, int height, int step) {
  std::vector<Corner> corners;
  for (int v = step / 2; v < height; v += step) {
    for (int u = step / 2; u < width; u += step) corners.push_back({u, v, 1.0f});
  }
  return corners;
}

TEST(SupportValueSalient, BestHypothesisIsTheTruthAtVisiblePoints) {
  const SyntheticPair p = makeLayeredPair(31, 192, 120, 4, 16);
  const std::vector<Corner> corners = gridCorners(192, 120, 7);
  StereoHypotheses hyps;
  ASSERT_TRUE(matchSupportValueSalient(p.left, p.right, corners, smallOptions(24), &hyps).isOk());
  ASSERT_EQ(hyps.points.size(), corners.size());
  size_t visible = 0, right_best = 0, consistent = 0;
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const SalientPoint& pt = hyps.points[i];
    EXPECT_EQ(pt.corner.u_px, corners[i].u_px);  // input order
    for (uint32_t k = 0; k < pt.num_hypotheses; ++k) {
      const DisparityHypothesis& h = hyps.hypotheses[pt.first_hypothesis + k];
      EXPECT_EQ(h.point_index, i);
      EXPECT_EQ(h.rank, k);
      if (k > 0) {
        EXPECT_GE(h.cost, hyps.hypotheses[pt.first_hypothesis + k - 1].cost);
      }
    }
    const int u = pt.corner.u_px, v = pt.corner.v_px;
    // Visible and away from the box edges, where a 13x13 window sees one surface.
    const bool near_edge = std::abs(u - 64) < 8 || std::abs(u - 128) < 8 || std::abs(u - 48) < 8 ||
                           std::abs(v - 30) < 8 || std::abs(v - 90) < 8;
    if (!p.visible(u, v) || near_edge || u < 24) continue;
    ++visible;
    if (pt.num_hypotheses == 0) continue;
    const DisparityHypothesis& best = hyps.hypotheses[pt.first_hypothesis];
    if (std::abs(best.d_px - p.truth(u, v)) <= kExactTol) {
      ++right_best;
      consistent += best.lr_consistent ? 1 : 0;
    }
  }
  ASSERT_GT(visible, 100u);
  EXPECT_GE(100.0 * static_cast<double>(right_best) / static_cast<double>(visible), 98.0);
  EXPECT_GE(100.0 * static_cast<double>(consistent) / static_cast<double>(right_best), 98.0);
}

TEST(SupportValueSalient, PeriodicTextureGivesRivalHypotheses) {
  // A texture repeating every 8 columns: the true disparity (5) and its aliases 13, 21 score
  // alike, so a point keeps several hypotheses.
  const int width = 120, height = 40, period = 8, d_true = 5;
  std::mt19937 rng(32);
  const std::vector<uint8_t> tile = texture(rng, period, height);
  ImageU8 left(width, height), right(width, height);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      left(u, v) = tile[static_cast<size_t>(v) * period + u % period];
      right(u, v) = tile[static_cast<size_t>(v) * period + (u + d_true) % period];
    }
  }
  SupportValueOptions o = smallOptions(30);
  StereoHypotheses hyps;
  ASSERT_TRUE(matchSupportValueSalient(left, right, {{80, 20, 1.0f}}, o, &hyps).isOk());
  ASSERT_EQ(hyps.points.size(), 1u);
  const SalientPoint& pt = hyps.points[0];
  EXPECT_GE(pt.num_hypotheses, 3u);
  bool has_truth = false;
  for (uint32_t k = 0; k < pt.num_hypotheses; ++k) {
    const float d = hyps.hypotheses[pt.first_hypothesis + k].d_px;
    EXPECT_EQ(static_cast<int>(d) % period, d_true) << d;
    has_truth = has_truth || d == static_cast<float>(d_true);
  }
  EXPECT_TRUE(has_truth);
  o.max_hypotheses = 2;
  ASSERT_TRUE(matchSupportValueSalient(left, right, {{80, 20, 1.0f}}, o, &hyps).isOk());
  EXPECT_EQ(hyps.points[0].num_hypotheses, 2u);
  EXPECT_FALSE(hyps.points[0].complete);  // an alias was dropped for want of room
}

TEST(SupportValueSalient, SkipsOutsideCornersAndKeepsOutputOnError) {
  const SyntheticPair p = makeLayeredPair(33, 96, 48, 3, 3);
  StereoHypotheses hyps;
  hyps.t_ns = 42;
  const std::vector<Corner> corners = {{-1, 5, 1.0f}, {40, 20, 1.0f}, {96, 5, 1.0f}, {3, 47, 1.0f}};
  ASSERT_TRUE(matchSupportValueSalient(p.left, p.right, corners, smallOptions(10), &hyps).isOk());
  ASSERT_EQ(hyps.points.size(), 2u);
  EXPECT_EQ(hyps.points[0].corner.u_px, 40);
  EXPECT_EQ(hyps.points[1].corner.u_px, 3);
  EXPECT_FALSE(hyps.points[1].complete);  // u = 3 < max disparity: the search was cut short
  EXPECT_EQ(hyps.t_ns, 42);
  const size_t n_points = hyps.points.size();
  SupportValueOptions bad = smallOptions(10);
  bad.max_hypotheses = 0;
  EXPECT_FALSE(matchSupportValueSalient(p.left, p.right, corners, bad, &hyps).isOk());
  EXPECT_FALSE(
      matchSupportValueSalient(p.left, ImageU8(), corners, smallOptions(10), &hyps).isOk());
  EXPECT_FALSE(
      matchSupportValueSalient(p.left, p.right, corners, smallOptions(10), nullptr).isOk());
  EXPECT_EQ(hyps.points.size(), n_points);
}

}  // namespace
}  // namespace twocam::frontend
