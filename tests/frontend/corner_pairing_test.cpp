#include "frontend/corner_pairing.h"

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
#include "frontend/salient_test_support.h"

namespace twocam::frontend {
namespace {

// ---------------------------------------------------------------------------------------------
// Paper A: corner pairing.

TEST(PairCorners, ReturnsTheTrueRightCorner) {
  constexpr int kD = 11;
  const cv::Mat tex = randomTexture(400, 140, 111);
  const StereoPair pair = shiftedPair(tex, 320, 120, kD);
  const std::vector<Corner> left_corners = gridCorners(80, 310, 5, 115, 10);
  std::vector<Corner> right_corners;
  std::mt19937 rng(112);
  std::uniform_int_distribution<int> offset(1, 60);
  for (const Corner& c : left_corners) {
    right_corners.push_back({c.u_px - kD, c.v_px, 1.0f});
    // A distractor in the same row inside the search range, never on a true right corner
    // (those sit at u - kD for the grid's u = 80 + 10 i).
    int ur = c.u_px - offset(rng);
    while ((ur + kD - 80) % 10 == 0) ur = c.u_px - offset(rng);
    right_corners.push_back({ur, c.v_px, 1.0f});
  }
  std::shuffle(right_corners.begin(), right_corners.end(), rng);
  SalientSadOptions options;
  StereoHypotheses out;
  ASSERT_TRUE(
      pairCorners(pair.left, pair.right, left_corners, right_corners, options, &out).isOk());
  ASSERT_EQ(out.points.size(), left_corners.size());
  expectWellFormed(out, options.max_hypotheses);
  size_t with_rivals = 0;
  for (const SalientPoint& p : out.points) {
    const DisparityHypothesis* h = best(out, p);
    ASSERT_NE(h, nullptr);
    EXPECT_EQ(h->d_px, static_cast<float>(kD));
    EXPECT_EQ(h->cost, 0.0f);
    EXPECT_TRUE(h->lr_consistent);
    for (uint32_t k = 1; k < p.num_hypotheses; ++k) {
      const DisparityHypothesis& rival = out.hypotheses[p.first_hypothesis + k];
      EXPECT_GT(rival.cost, 0.0f);
      EXPECT_GE(rival.d_px, options.min_disparity_px);
      EXPECT_LE(rival.d_px, options.max_disparity_px);
    }
    if (p.num_hypotheses > 1) ++with_rivals;
  }
  // Each row holds 23 left corners' distractors, so most points see several right corners.
  EXPECT_GE(with_rivals, out.points.size() * 9 / 10);
}

TEST(PairCorners, RowToleranceWidensTheWindow) {
  constexpr int kD = 8;
  const cv::Mat tex = randomTexture(400, 140, 121);
  const StereoPair pair = shiftedPair(tex, 320, 120, kD, 1);  // right one row low
  const std::vector<Corner> left_corners = gridCorners(80, 310, 5, 110, 10);
  std::vector<Corner> right_corners;
  for (const Corner& c : left_corners) right_corners.push_back({c.u_px - kD, c.v_px + 1, 1.0f});
  SalientSadOptions options;
  StereoHypotheses out;
  ASSERT_TRUE(
      pairCorners(pair.left, pair.right, left_corners, right_corners, options, &out).isOk());
  EXPECT_TRUE(out.hypotheses.empty());  // m = 0: no right corner on the same row
  options.row_tolerance_px = 1;
  ASSERT_TRUE(
      pairCorners(pair.left, pair.right, left_corners, right_corners, options, &out).isOk());
  ASSERT_EQ(out.points.size(), left_corners.size());
  for (const SalientPoint& p : out.points) {
    const DisparityHypothesis* h = best(out, p);
    ASSERT_NE(h, nullptr);
    EXPECT_EQ(h->d_px, static_cast<float>(kD));
    EXPECT_EQ(h->row_offset_px, 1);
    EXPECT_EQ(h->cost, 0.0f);
  }
}

TEST(PairCorners, KeepsTheKCheapestAndFlagsMutualBest) {
  // One left corner, many right corners in its row: K = 2 keeps the two cheapest. A second
  // left corner that is the exact match of right corner X makes the first's pairing with X
  // not mutual-best.
  const cv::Mat tex = randomTexture(300, 20, 131);
  cv::Mat left = tex(cv::Rect(0, 0, 200, 9)).clone();
  cv::Mat right = tex(cv::Rect(0, 0, 200, 9)).clone();  // d = 0 everywhere
  const int row = 4;
  const std::vector<Corner> left_corners = {{120, row, 1.0f}, {100, row, 1.0f}};
  std::vector<Corner> right_corners;
  for (int u = 60; u <= 120; u += 5) right_corners.push_back({u, row, 1.0f});
  SalientSadOptions options;
  options.max_hypotheses = 2;
  StereoHypotheses out;
  ASSERT_TRUE(
      pairCorners(toImageU8(left), toImageU8(right), left_corners, right_corners, options, &out)
          .isOk());
  ASSERT_EQ(out.points.size(), 2u);
  expectWellFormed(out, 2);
  // Left 120 pairs with right 120 (d = 0, exact), left 100 with right 100 (exact).
  const DisparityHypothesis* a = best(out, out.points[0]);
  const DisparityHypothesis* b = best(out, out.points[1]);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  EXPECT_EQ(a->d_px, 0.0f);
  EXPECT_TRUE(a->lr_consistent);
  EXPECT_EQ(b->d_px, 0.0f);
  EXPECT_TRUE(b->lr_consistent);
  ASSERT_EQ(out.points[0].num_hypotheses, 2u);
  const DisparityHypothesis& a2 = out.hypotheses[out.points[0].first_hypothesis + 1];
  EXPECT_GT(a2.cost, 0.0f);
  // If a2 points at right corner 100 (d = 20), left 100 beats it there exactly.
  if (a2.d_px == 20.0f) {
    EXPECT_FALSE(a2.lr_consistent);
  }
}

}  // namespace
}  // namespace twocam::frontend
