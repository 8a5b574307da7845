#include "frontend/row_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
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

/// Row support of a hypothesis whose rows all see the same fronto-parallel plane: the parabola
/// offsets of the three rows differ by at most twice kIntegerShiftTolPx.
constexpr double kPlaneRowSpanTolPx = 2 * kIntegerShiftTolPx;

TEST(RowSupport, PlaneHasNarrowSpansAndAHorizontalDepthEdgeWideOnes) {
  // Rows 0..59 of the scene at disparity 12, rows 60.. at 15 (a horizontal depth edge whose
  // step equals the search radius, so the other surface's match is inside it).
  constexpr int kFar = 12;
  constexpr int kNear = 15;
  constexpr int kEdgeRow = 60;
  const cv::Mat tex = randomTexture(400, 140, 41);
  const StereoPair far = shiftedPair(tex, 320, 120, kFar);
  const StereoPair near = shiftedPair(tex, 320, 120, kNear);
  ImageU8 right = far.right;
  for (int v = kEdgeRow; v < right.height; ++v) {
    std::copy(
        near.right.row(v), near.right.row(v) + right.width, right.data.begin() + v * right.width);
  }
  const std::vector<Corner> corners = gridCorners(80, 300, 0, 120, 3);
  SalientSadOptions options;
  StereoHypotheses out;
  ASSERT_TRUE(matchSalient(far.left, right, corners, options, &out).isOk());
  for (const DisparityHypothesis& h : out.hypotheses)
    EXPECT_EQ(h.row_span_px, 0.0f);  // not measured
  ASSERT_TRUE(measureRowSupport(far.left, right, options, &out).isOk());
  int checked_plane = 0;
  int checked_edge = 0;
  for (const SalientPoint& p : out.points) {
    const DisparityHypothesis* h = best(out, p);
    ASSERT_NE(h, nullptr);
    const int v = p.corner.v_px;
    const bool at_edge = v == kEdgeRow - 1 || v == kEdgeRow;
    const double truth = v < kEdgeRow ? kFar : kNear;
    if (std::abs(h->d_px - truth) > kIntegerShiftTolPx) continue;  // only the true best matches
    if (at_edge) {
      // One neighbouring row lies on the other surface, 3 px away.
      EXPECT_NEAR(h->row_span_px, kNear - kFar, kPlaneRowSpanTolPx) << "v = " << v;
      ++checked_edge;
    } else if (std::abs(v - kEdgeRow) > 2) {
      EXPECT_LE(h->row_span_px, kPlaneRowSpanTolPx) << "v = " << v;
      ++checked_plane;
    }
  }
  EXPECT_GT(checked_plane, 500);
  EXPECT_GT(checked_edge, 50);
}

TEST(RowSupport, AWrongDisparityHasNoSupportAndBordersUseTheRowsThatExist) {
  constexpr int kD = 17;
  const cv::Mat tex = randomTexture(400, 140, 43);
  const StereoPair pair = shiftedPair(tex, 320, 120, kD);
  StereoHypotheses hyps;
  // Point 0 in the image, point 1 on row 0 (no row above), point 2 on the last row.
  for (const int v : {50, 0, 119}) {
    SalientPoint p;
    p.corner = {150, v, 1.0f};
    p.first_hypothesis = static_cast<uint32_t>(hyps.hypotheses.size());
    p.num_hypotheses = 2;
    DisparityHypothesis right_d;
    right_d.d_px = kD;
    right_d.point_index = static_cast<uint32_t>(hyps.points.size());
    DisparityHypothesis wrong_d = right_d;
    wrong_d.d_px = kD + 3;  // the neighbouring rows match at the truth, 3 px away
    wrong_d.rank = 1;
    hyps.hypotheses.push_back(right_d);
    hyps.hypotheses.push_back(wrong_d);
    hyps.points.push_back(p);
  }
  SalientSadOptions options;
  ASSERT_TRUE(measureRowSupport(pair.left, pair.right, options, &hyps).isOk());
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const DisparityHypothesis& right_d = hyps.hypotheses[hyps.points[i].first_hypothesis];
    const DisparityHypothesis& wrong_d = hyps.hypotheses[hyps.points[i].first_hypothesis + 1];
    EXPECT_LE(right_d.row_span_px, kPlaneRowSpanTolPx) << "point " << i;
    EXPECT_NEAR(wrong_d.row_span_px, 3.0, kPlaneRowSpanTolPx) << "point " << i;
  }
  // A radius of 1 px cannot reach the truth from the wrong disparity: a smaller span.
  StereoHypotheses narrow = hyps;
  options.row_support_radius_px = 1;
  ASSERT_TRUE(measureRowSupport(pair.left, pair.right, options, &narrow).isOk());
  EXPECT_LT(narrow.hypotheses[1].row_span_px, hyps.hypotheses[1].row_span_px - 0.5f);

  // Bad input: an error, hypotheses untouched.
  StereoHypotheses broken = hyps;
  broken.points[2].num_hypotheses = 3;  // one past the end of the hypotheses
  broken.hypotheses[0].row_span_px = -1.0f;
  EXPECT_FALSE(measureRowSupport(pair.left, pair.right, options, &broken).isOk());
  EXPECT_EQ(broken.hypotheses[0].row_span_px, -1.0f);
  ImageU8 small = pair.right;
  small.height -= 1;
  small.data.resize(static_cast<size_t>(small.width) * small.height);
  EXPECT_FALSE(measureRowSupport(pair.left, small, options, &hyps).isOk());
  options.row_support_radius_px = 0;
  EXPECT_FALSE(measureRowSupport(pair.left, pair.right, options, &hyps).isOk());
  EXPECT_NE(options.validate().message().find("row_support_radius_px"), std::string::npos);
}

// Hypotheses no matcher produces (a corner far outside the image, d_px NaN or huge) are errors,
// not overflowing column arithmetic (UBSan: u_px + shift - W / 2 and int(d_px + 0.5)).
TEST(RowSupport, RejectsHypothesesNoMatcherProduces) {
  const cv::Mat tex = randomTexture(400, 140, 44);
  const StereoPair pair = shiftedPair(tex, 320, 120, 9);
  auto one = [](int u, int v, float d) {
    StereoHypotheses hyps;
    SalientPoint p;
    p.corner = {u, v, 1.0f};
    p.num_hypotheses = 1;
    DisparityHypothesis h;
    h.d_px = d;
    hyps.points.push_back(p);
    hyps.hypotheses.push_back(h);
    return hyps;
  };
  const SalientSadOptions options;
  struct Case {
    int u;
    int v;
    float d;
    const char* what;
  };
  for (const Case& c : {Case{std::numeric_limits<int>::max(), 50, 9.0f, "corner"},
                        Case{150, std::numeric_limits<int>::min(), 9.0f, "corner"},
                        Case{150, 50, std::numeric_limits<float>::quiet_NaN(), "d_px"},
                        Case{150, 50, 3e9f, "d_px"},
                        Case{150, 50, -1.0f, "d_px"}}) {
    StereoHypotheses hyps = one(c.u, c.v, c.d);
    hyps.hypotheses[0].row_span_px = 7.0f;
    const Status s = measureRowSupport(pair.left, pair.right, options, &hyps);
    EXPECT_FALSE(s.isOk()) << c.u << " " << c.v << " " << c.d;
    EXPECT_NE(s.message().find(c.what), std::string::npos) << s.message();
    EXPECT_EQ(hyps.hypotheses[0].row_span_px, 7.0f);  // untouched
  }
  StereoHypotheses fine = one(150, 50, 9.0f);
  EXPECT_TRUE(measureRowSupport(pair.left, pair.right, options, &fine).isOk());
}

TEST(RowSupport, EveryKernelGivesTheSameSpans) {
  // The AVX2 / SSE4.1 fast path (plain SAD) and the generic one must agree bit for bit, at
  // the image borders and for rivals too: hypotheses of a real matcher run on a slanted scene.
  const cv::Mat tex = randomTexture(420, 160, 47);
  cv::Mat right_m(120, 320, CV_8U);
  for (int v = 0; v < 120; ++v) {
    const int d = 5 + v / 6;  // disparity grows down the image, 5..24 px
    tex(cv::Rect(d, 8 + v, 320, 1)).copyTo(right_m.row(v));
  }
  const ImageU8 left = toImageU8(tex(cv::Rect(0, 8, 320, 120)).clone());
  const ImageU8 right = toImageU8(right_m);
  const std::vector<Corner> corners = gridCorners(5, 315, 0, 120, 3);
  for (const int radius : {1, 3, 5}) {
    for (const int window : {5, 11, 15, 21}) {
      SalientSadOptions options;
      options.max_disparity_px = 31;
      options.window_width_px = window;
      options.row_support_radius_px = radius;
      StereoHypotheses reference;
      ASSERT_TRUE(matchSalient(left, right, corners, options, &reference).isOk());
      StereoHypotheses fast = reference;
      options.simd = Simd::kScalar;
      ASSERT_TRUE(measureRowSupport(left, right, options, &reference).isOk());
      options.simd = Simd::kAuto;
      ASSERT_TRUE(measureRowSupport(left, right, options, &fast).isOk());
      ASSERT_EQ(fast.hypotheses.size(), reference.hypotheses.size());
      int nonzero = 0;
      for (size_t j = 0; j < fast.hypotheses.size(); ++j) {
        ASSERT_EQ(fast.hypotheses[j].row_span_px, reference.hypotheses[j].row_span_px)
            << "hypothesis " << j << ", W = " << window << ", radius " << radius;
        if (reference.hypotheses[j].row_span_px > 0.0f) ++nonzero;
      }
      EXPECT_GT(nonzero, static_cast<int>(fast.hypotheses.size()) / 2);
    }
  }
}

}  // namespace
}  // namespace twocam::frontend
