#include "frontend/salient_sad.h"

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

#include "frontend/corner_pairing.h"
#include "frontend/cv_interop.h"
#include "frontend/frontend.h"
#include "frontend/salient_test_support.h"
#include "support/test_paths.h"

namespace twocam::frontend {
namespace {

// ---------------------------------------------------------------------------------------------

TEST(SalientSadOptions, DefaultsAreValid) {
  EXPECT_TRUE(SalientSadOptions{}.validate().isOk());
  EXPECT_EQ(SalientSadOptions{}.window_width_px, 11);
  EXPECT_EQ(SalientSadOptions{}.max_disparity_px - SalientSadOptions{}.min_disparity_px + 1, 64);
}

TEST(SalientSadOptions, NamesTheBrokenConstraint) {
  struct Case {
    SalientSadOptions options;
    std::string field;
  };
  std::vector<Case> cases;
  auto add = [&cases](const std::string& field, auto mutate) {
    SalientSadOptions o;
    mutate(o);
    cases.push_back({o, field});
  };
  add("window_width_px", [](SalientSadOptions& o) { o.window_width_px = 10; });
  add("window_width_px", [](SalientSadOptions& o) { o.window_width_px = 1; });
  add("window_width_px", [](SalientSadOptions& o) { o.window_width_px = 65; });
  add("min_disparity_px", [](SalientSadOptions& o) { o.min_disparity_px = -1; });
  add("max_disparity_px", [](SalientSadOptions& o) { o.max_disparity_px = -2; });
  add("max_disparity_px - min_disparity_px",
      [](SalientSadOptions& o) { o.max_disparity_px = 300; });
  add("row_tolerance_px", [](SalientSadOptions& o) { o.row_tolerance_px = -1; });
  add("row_tolerance_px", [](SalientSadOptions& o) { o.row_tolerance_px = 9; });
  add("max_hypotheses", [](SalientSadOptions& o) { o.max_hypotheses = 0; });
  add("max_hypotheses", [](SalientSadOptions& o) { o.max_hypotheses = 256; });
  add("cost_ratio", [](SalientSadOptions& o) { o.cost_ratio = 0.9f; });
  add("cost_ratio", [](SalientSadOptions& o) { o.cost_ratio = NAN; });
  add("complete_cost_ratio", [](SalientSadOptions& o) { o.complete_cost_ratio = 2.0f; });
  add("min_separation_px", [](SalientSadOptions& o) { o.min_separation_px = 0; });
  add("lr_tolerance_px", [](SalientSadOptions& o) { o.lr_tolerance_px = -1; });
  add("max_cost_per_px", [](SalientSadOptions& o) { o.max_cost_per_px = 0.0f; });
  add("max_cost_per_px", [](SalientSadOptions& o) { o.max_cost_per_px = INFINITY; });
  // Upper bounds the code can honour (UBSan: lr_tolerance_px = INT_MAX overflowed d +- tolerance
  // in the right-to-left check; max_disparity_px = INT_MAX overflowed max - min + 1 here and
  // max + W in the input check).
  constexpr int kIntMax = std::numeric_limits<int>::max();
  add("lr_tolerance_px", [](SalientSadOptions& o) { o.lr_tolerance_px = kIntMax; });
  add("lr_tolerance_px", [](SalientSadOptions& o) { o.lr_tolerance_px = 257; });
  add("min_separation_px", [](SalientSadOptions& o) { o.min_separation_px = kIntMax; });
  add("max_disparity_px", [](SalientSadOptions& o) { o.max_disparity_px = kIntMax; });
  add("min_disparity_px", [](SalientSadOptions& o) {
    o.min_disparity_px = kIntMax - 1;
    o.max_disparity_px = kIntMax;
  });
  add("window_width_px", [](SalientSadOptions& o) { o.window_width_px = kIntMax; });
  add("row_tolerance_px", [](SalientSadOptions& o) { o.row_tolerance_px = kIntMax; });
  add("max_hypotheses", [](SalientSadOptions& o) { o.max_hypotheses = kIntMax; });
  add("row_support_radius_px", [](SalientSadOptions& o) { o.row_support_radius_px = kIntMax; });
  add("complete_cost_ratio", [](SalientSadOptions& o) { o.complete_cost_ratio = NAN; });
  add("complete_cost_ratio", [](SalientSadOptions& o) { o.complete_cost_ratio = INFINITY; });
  add("max_cost_per_px", [](SalientSadOptions& o) { o.max_cost_per_px = NAN; });
  for (const Case& c : cases) {
    const Status s = c.options.validate();
    ASSERT_FALSE(s.isOk()) << c.field;
    EXPECT_NE(s.message().find(c.field), std::string::npos) << s.message();
  }
}

// The largest accepted tolerance and separation run through the matcher (and its right-to-left
// check) like any other value: the tolerance wider than the range accepts every hypothesis.
TEST(SalientSadOptions, LargestAcceptedBoundsMatch) {
  const cv::Mat tex = randomTexture(400, 120, 5);
  const StereoPair pair = shiftedPair(tex, 320, 96, 12);
  SalientSadOptions options;
  options.lr_tolerance_px = 256;
  options.min_separation_px = 256;
  ASSERT_TRUE(options.validate().isOk()) << options.validate().message();
  StereoHypotheses out;
  ASSERT_TRUE(
      matchSalient(pair.left, pair.right, gridCorners(80, 300, 20, 80, 20), options, &out).isOk());
  ASSERT_FALSE(out.hypotheses.empty());
  for (const DisparityHypothesis& h : out.hypotheses) EXPECT_TRUE(h.lr_consistent);
  for (const SalientPoint& p : out.points) EXPECT_LE(p.num_hypotheses, 1u);  // one per range
}

TEST(SalientSad, RejectsBadInput) {
  const cv::Mat tex = randomTexture(200, 80, 11);
  const StereoPair pair = shiftedPair(tex, 160, 60, 5);
  const std::vector<Corner> corners = gridCorners(20, 140, 10, 50, 10);
  const SalientSadOptions options;

  StereoHypotheses out;
  out.points.resize(3);  // must stay untouched on error
  auto expect_error = [&](const ImageU8& l,
                          const ImageU8& r,
                          const SalientSadOptions& o,
                          const std::string& needle) {
    Status s = matchSalient(l, r, corners, o, &out);
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find(needle), std::string::npos) << s.message();
    s = pairCorners(l, r, corners, corners, o, &out);
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find(needle), std::string::npos) << s.message();
    EXPECT_EQ(out.points.size(), 3u);
  };
  expect_error(ImageU8(), pair.right, options, "empty");
  expect_error(pair.left, ImageU8(), options, "empty");
  expect_error(pair.left, ImageU8(161, 60), options, "sizes differ");
  expect_error(pair.left, ImageU8(160, 59), options, "sizes differ");
  ImageU8 broken = pair.right;
  broken.data.pop_back();
  expect_error(pair.left, broken, options, "buffer size");
  SalientSadOptions too_wide;
  too_wide.max_disparity_px = 150;  // 150 + 11 > 160
  expect_error(pair.left, pair.right, too_wide, "exceeds the image width");
  SalientSadOptions bad;
  bad.cost_ratio = 0.5f;
  expect_error(pair.left, pair.right, bad, "cost_ratio");

  EXPECT_FALSE(matchSalient(pair.left, pair.right, corners, options, nullptr).isOk());
  EXPECT_FALSE(pairCorners(pair.left, pair.right, corners, corners, options, nullptr).isOk());
}

TEST(SalientSad, IntegerShiftFindsTrueDisparityConsistently) {
  constexpr int kD = 17;
  const cv::Mat tex = randomTexture(400, 140, 21);
  const StereoPair pair = shiftedPair(tex, 320, 120, kD);
  // u >= 80 so the true disparity is searchable (u - h >= 63 covers the whole range).
  const std::vector<Corner> corners = gridCorners(80, 310, 5, 115, 7);
  StereoHypotheses out;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, SalientSadOptions{}, &out).isOk());
  ASSERT_EQ(out.points.size(), corners.size());
  expectWellFormed(out, 4);
  for (const SalientPoint& p : out.points) {
    const DisparityHypothesis* h = best(out, p);
    ASSERT_NE(h, nullptr);
    EXPECT_NEAR(h->d_px, kD, kIntegerShiftTolPx)
        << "corner " << p.corner.u_px << "," << p.corner.v_px;
    EXPECT_EQ(h->cost, 0.0f);
    EXPECT_EQ(h->row_offset_px, 0);
    EXPECT_TRUE(h->lr_consistent);
  }
}

// Frontend::measureAt runs the frame's matcher (and row support) at chosen pixels: what the
// landmark database re-measures a candidate with when its corner was not detected.
TEST(Frontend, MeasureAtMatchesTheGivenPixelsInOrder) {
  constexpr int kD = 17;
  const cv::Mat tex = randomTexture(400, 140, 21);
  const StereoPair pair = shiftedPair(tex, 320, 120, kD);
  StereoFrame frame;
  frame.t_ns = 42;
  frame.left = pair.left;
  frame.right = pair.right;
  FrontendOptions options;
  options.sad.row_support = true;
  const Frontend frontend(options);
  // The second pixel's window leaves the image: it is skipped, the others keep their order.
  const std::vector<Corner> pixels = {
      {200, 40, 0.0f}, {2, 40, 0.0f}, {90, 100, 0.0f}, {150, 60, 0.0f}};
  StereoHypotheses out;
  ASSERT_TRUE(frontend.measureAt(frame, pixels, &out).isOk());
  EXPECT_EQ(out.t_ns, 42);
  ASSERT_EQ(out.points.size(), 3u);
  EXPECT_EQ(out.points[0].corner.u_px, 200);
  EXPECT_EQ(out.points[1].corner.u_px, 90);
  EXPECT_EQ(out.points[2].corner.u_px, 150);
  for (const SalientPoint& p : out.points) {
    const DisparityHypothesis* h = best(out, p);
    ASSERT_NE(h, nullptr);
    EXPECT_NEAR(h->d_px, kD, kIntegerShiftTolPx);
    EXPECT_EQ(h->window_shift_px, 0) << "centred window only";
    EXPECT_FALSE(h->lr_consistent) << "no right-to-left check";
    // Row support was measured: a fronto-parallel plane matches one row up and down alike.
    EXPECT_LE(h->row_span_px, kIntegerShiftTolPx);
  }
  StereoFrame bad = frame;
  bad.right = ImageU8();
  EXPECT_FALSE(frontend.measureAt(bad, pixels, &out).isOk());
}

TEST(SalientSad, BorderTruncatedSearchEndIsNotAHypothesis) {
  // Corners closer to the left edge than their true disparity: the match lies outside the
  // right image, the search stops at d = u (window starting at u, right window at column 0),
  // and that end of the cost curve must not be reported as a minimum of the cost.
  constexpr int kD = 30;
  const cv::Mat tex = randomTexture(400, 140, 5);
  const StereoPair pair = shiftedPair(tex, 320, 120, kD);
  const std::vector<Corner> corners = gridCorners(8, 24, 5, 115, 3);
  StereoHypotheses out;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, SalientSadOptions{}, &out).isOk());
  expectWellFormed(out, 4);
  int hypotheses = 0;
  for (const SalientPoint& p : out.points) {
    for (uint32_t k = 0; k < p.num_hypotheses; ++k) {
      const DisparityHypothesis& h = out.hypotheses[p.first_hypothesis + k];
      ++hypotheses;
      // The largest searchable disparity is u; an interior minimum at u - 1 may move by up
      // to half a pixel with the parabola fit.
      EXPECT_LE(h.d_px, static_cast<float>(p.corner.u_px) - 0.5f + 1e-3f)
          << "corner " << p.corner.u_px << "," << p.corner.v_px;
    }
  }
  std::printf("[          ] %d hypotheses at %zu border corners\n", hypotheses, out.points.size());
}

/// f(x, y): a band-limited random texture (48 seeded plane waves, periods 6..40 px, grey
/// standard deviation ~35) sampled exactly at any x, so a sub-pixel shift needs no
/// interpolation.
cv::Mat waveTexture(int width, int height, double x_shift, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> freq(1.0 / 40.0, 1.0 / 6.0);
  std::uniform_real_distribution<double> yfreq(-0.1, 0.1);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * M_PI);
  struct Wave {
    double fx, fy, phi, amp;
  };
  std::vector<Wave> waves;
  for (int k = 0; k < 48; ++k) waves.push_back({freq(rng), yfreq(rng), phase(rng), 7.0});
  cv::Mat img(height, width, CV_8U);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      double f = 128.0;
      for (const Wave& wv : waves) {
        f += wv.amp * std::sin(2.0 * M_PI * (wv.fx * (u + x_shift) + wv.fy * v) + wv.phi);
      }
      img.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(f);
    }
  }
  return img;
}

TEST(SalientSad, SubpixelShiftParabolaWithinTolerance) {
  // Half-pixel shifts are the hard case for integer SAD: both neighbouring integer costs are
  // high and a random look-alike elsewhere may undercut them, so the truth is then a rival
  // (rank > 0). The parabola's accuracy is measured on the hypothesis nearest the truth.
  const std::vector<double> shifts = {10.0, 10.25, 10.5, 10.75, 23.1, 23.4, 31.6, 31.9};
  const std::vector<Corner> corners = gridCorners(80, 300, 10, 70, 9);
  const cv::Mat left = waveTexture(320, 80, 0.0, 5);
  for (double d : shifts) {
    const cv::Mat right = waveTexture(320, 80, d, 5);  // right(u) = f(u + d) = left(u + d)
    StereoHypotheses out;
    ASSERT_TRUE(matchSalient(toImageU8(left), toImageU8(right), corners, {}, &out).isOk());
    double sum_abs = 0.0;
    double max_abs = 0.0;
    size_t best_correct = 0;
    for (const SalientPoint& p : out.points) {
      double err = 1e9;
      for (uint32_t k = 0; k < p.num_hypotheses; ++k) {
        err = std::min(err, std::abs(out.hypotheses[p.first_hypothesis + k].d_px - d));
      }
      ASSERT_LE(err, kTruthTolPx) << "d = " << d << ": truth not among the hypotheses";
      sum_abs += err;
      max_abs = std::max(max_abs, err);
      if (std::abs(best(out, p)->d_px - d) <= kTruthTolPx) ++best_correct;
    }
    const double mean_abs = sum_abs / static_cast<double>(out.points.size());
    const double best_pct =
        100.0 * static_cast<double>(best_correct) / static_cast<double>(out.points.size());
    EXPECT_LE(mean_abs, kSubpixelMeanAbsTolPx) << "d = " << d;
    EXPECT_LE(max_abs, kSubpixelMaxAbsTolPx) << "d = " << d;
    EXPECT_GE(best_pct, kMinSubpixelBestCorrectPct) << "d = " << d;
    std::printf(
        "[ subpixel ] d = %5.2f  nearest hypothesis: mean |err| %.3f px, max %.3f px; "
        "best within 1 px: %5.1f %%\n",
        d,
        mean_abs,
        max_abs,
        best_pct);
  }
}

/// Bars 2-7 px wide along x with random grey levels in [30, 220], a new set every 10 rows,
/// area-sampled (a pixel is the mean over its width) at any x_shift: a sub-pixel shift blurs
/// the edges exactly as a camera would, and the unshifted image keeps them sharp.
cv::Mat barTexture(int width, int height, double x_shift, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> bar_width(2.0, 7.0);
  std::uniform_real_distribution<double> level(30.0, 220.0);
  cv::Mat img(height, width, CV_8U);
  for (int band = 0; band * 10 < height; ++band) {
    // Bar k spans [edges[k], edges[k + 1]) at levels[k]; the same bars whatever x_shift
    // (<= 64), so that every band of two images matches.
    std::vector<double> edges = {-10.0};
    std::vector<double> levels;
    while (edges.back() < width + 74.0) {
      edges.push_back(edges.back() + bar_width(rng));
      levels.push_back(level(rng));
    }
    for (int u = 0; u < width; ++u) {
      const double lo = u + x_shift - 0.5;
      const double hi = lo + 1.0;
      double value = 0.0;
      for (size_t k = 0; k + 1 < edges.size(); ++k) {
        const double overlap = std::min(hi, edges[k + 1]) - std::max(lo, edges[k]);
        if (overlap > 0.0) value += overlap * levels[k];
      }
      for (int v = band * 10; v < std::min(height, band * 10 + 10); ++v) {
        img.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(value);
      }
    }
  }
  return img;
}

TEST(SalientSad, BirchfieldTomasiKeepsHalfPixelMatchesCheap) {
  // Sharp edges, real disparity half a pixel off the grid: SAD pays for every blurred edge at
  // both neighbouring integers, the interval cost hardly at all. At an integer shift the two
  // costs find the same disparities.
  const std::vector<Corner> corners = gridCorners(80, 300, 3, 77, 5);
  const cv::Mat left = barTexture(320, 80, 0.0, 7);
  SalientSadOptions sad;
  SalientSadOptions bt;
  bt.birchfield_tomasi = true;
  for (double d : {12.0, 10.5, 17.5, 23.5}) {
    const cv::Mat right = barTexture(320, 80, d, 7);  // right(u) = left(u + d)
    double mean_cost[2] = {0.0, 0.0};
    double best_correct_pct[2] = {0.0, 0.0};
    for (int k = 0; k < 2; ++k) {
      StereoHypotheses out;
      ASSERT_TRUE(
          matchSalient(toImageU8(left), toImageU8(right), corners, k == 0 ? sad : bt, &out).isOk());
      expectWellFormed(out, sad.max_hypotheses);
      size_t correct = 0;
      for (const SalientPoint& p : out.points) {
        const DisparityHypothesis* h = best(out, p);
        ASSERT_NE(h, nullptr);
        mean_cost[k] += h->cost / static_cast<double>(out.points.size());
        if (std::abs(h->d_px - d) <= kTruthTolPx) ++correct;
      }
      best_correct_pct[k] = 100.0 * static_cast<double>(correct) / out.points.size();
    }
    std::printf(
        "[ bars     ] d = %4.1f  best cost SAD %6.1f, BT %6.1f; best within 1 px: SAD %5.1f %%, "
        "BT %5.1f %%\n",
        d,
        mean_cost[0],
        mean_cost[1],
        best_correct_pct[0],
        best_correct_pct[1]);
    EXPECT_GE(best_correct_pct[1], best_correct_pct[0]) << "d = " << d;
    if (d == std::round(d)) {
      EXPECT_DOUBLE_EQ(best_correct_pct[1], 100.0);
    } else {
      EXPECT_LT(mean_cost[1], kMaxHalfPixelCostRatio * mean_cost[0]) << "d = " << d;
    }
  }
}
TEST(SalientSad, PeriodicTextureGivesAliasesIncludingTruth) {
  // Columns repeat with a 12 px period (plus independent noise in each view): the true
  // disparity 14 and its aliases 2 and 26 cost about the same inside the 0..31 search.
  constexpr int kD = 14;
  constexpr int kPeriod = 12;
  const cv::Mat cell = randomTexture(kPeriod, 100, 31);
  cv::Mat tex(100, 400, CV_8U);
  for (int u = 0; u < tex.cols; ++u) cell.col(u % kPeriod).copyTo(tex.col(u));
  StereoPair pair = shiftedPair(tex, 300, 80, kD);
  std::mt19937 rng(32);
  std::normal_distribution<double> noise(0.0, 2.0);
  for (ImageU8* img : {&pair.left, &pair.right}) {
    for (uint8_t& px : img->data) px = cv::saturate_cast<uint8_t>(px + noise(rng));
  }
  SalientSadOptions options;
  options.max_disparity_px = 31;
  const std::vector<Corner> corners = gridCorners(60, 290, 5, 75, 7);
  StereoHypotheses out;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &out).isOk());
  expectWellFormed(out, options.max_hypotheses);
  size_t several = 0;
  for (const SalientPoint& p : out.points) {
    EXPECT_TRUE(anyWithin(out, p, kD, kTruthTolPx));
    if (p.num_hypotheses >= 3 && anyWithin(out, p, kD - kPeriod, kTruthTolPx) &&
        anyWithin(out, p, kD + kPeriod, kTruthTolPx)) {
      ++several;
    }
  }
  // Most points list all three aliases (noise may push one beyond cost_ratio now and then).
  EXPECT_GE(several, out.points.size() * 9 / 10);
}

TEST(SalientSad, CompleteFlagsOnlyListsThatHoldEveryCandidate) {
  // A unique match with the whole range searchable: complete.
  {
    const cv::Mat tex = randomTexture(400, 140, 21);
    const StereoPair pair = shiftedPair(tex, 320, 120, 17);
    const std::vector<Corner> corners = gridCorners(80, 310, 5, 115, 7);
    StereoHypotheses out;
    ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, SalientSadOptions{}, &out).isOk());
    size_t complete = 0;
    for (const SalientPoint& p : out.points) complete += p.complete ? 1 : 0;
    EXPECT_GE(complete, out.points.size() * 95 / 100);
    // Corners nearer the left edge than the largest disparity: the search is cut short.
    StereoHypotheses border;
    ASSERT_TRUE(
        matchSalient(pair.left, pair.right, gridCorners(8, 60, 5, 115, 5), {}, &border).isOk());
    for (const SalientPoint& p : border.points)
      EXPECT_FALSE(p.complete) << "corner u = " << p.corner.u_px;
  }
  // Row 40 of two unrelated textures; the left window of the corner at u = 200 is copied into
  // the right row at disparities 29 and 47 (+2 grey: cost 22) and, 4.5x as dear (+9 grey: cost
  // 99, beyond cost_ratio 3), at a third disparity.
  const auto build = [](int third_d, SalientSadOptions options) {
    cv::Mat left = randomTexture(320, 80, 41);
    cv::Mat right = randomTexture(320, 80, 42);
    constexpr int kU = 200;
    constexpr int kV = 40;
    for (const auto& [d, add] : {std::pair{29, 2}, std::pair{47, 2}, std::pair{third_d, 9}}) {
      for (int i = -5; i <= 5; ++i) {
        right.at<uint8_t>(kV, kU - d + i) =
            cv::saturate_cast<uint8_t>(left.at<uint8_t>(kV, kU + i) + add);
      }
    }
    StereoHypotheses out;
    EXPECT_TRUE(
        matchSalient(toImageU8(left), toImageU8(right), {{kU, kV, 1.0f}}, options, &out).isOk());
    return out;
  };
  // At 11 the third copy continues the period of 29 and 47: the real disparity may be there.
  const StereoHypotheses periodic = build(11, {});
  ASSERT_EQ(periodic.points.size(), 1u);
  ASSERT_EQ(periodic.points[0].num_hypotheses, 2u);
  EXPECT_TRUE(anyWithin(periodic, periodic.points[0], 29, kTruthTolPx));
  EXPECT_TRUE(anyWithin(periodic, periodic.points[0], 47, kTruthTolPx));
  EXPECT_FALSE(periodic.points[0].complete);
  // At 15 it continues nothing: the list is complete.
  const StereoHypotheses unrelated = build(15, {});
  ASSERT_EQ(unrelated.points[0].num_hypotheses, 2u);
  EXPECT_TRUE(unrelated.points[0].complete);
  // With complete_cost_ratio at cost_ratio, the dear copy is not looked for.
  SalientSadOptions narrow;
  narrow.complete_cost_ratio = narrow.cost_ratio;
  EXPECT_TRUE(build(11, narrow).points[0].complete);
  // No room for the second alias: incomplete.
  SalientSadOptions one;
  one.max_hypotheses = 1;
  const StereoHypotheses truncated = build(15, one);
  ASSERT_EQ(truncated.points[0].num_hypotheses, 1u);
  EXPECT_FALSE(truncated.points[0].complete);
}

TEST(SalientSad, LrFlagRejectsConstructedFalseMatch) {
  // Left corner A at u = 100 matches the right window at u = 95 (d = 5) only approximately;
  // the left image also holds an exact copy of that right window at u = 110 (corner B,
  // d = 15). Right-to-left from u = 95 lands on B, so A's match is inconsistent, B's is not.
  constexpr int kW = 11;
  constexpr int kH = kW / 2;
  const cv::Mat tex = randomTexture(300, 20, 41);
  cv::Mat left = tex(cv::Rect(0, 0, 200, 9)).clone();
  cv::Mat right = tex(cv::Rect(100, 10, 200, 9)).clone();  // unrelated texture
  const int row = 4;
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> jitter(-3, 3);
  for (int i = -kH; i <= kH; ++i) {
    const uint8_t a = left.at<uint8_t>(row, 100 + i);
    const uint8_t noisy = cv::saturate_cast<uint8_t>(a + jitter(rng));
    right.at<uint8_t>(row, 95 + i) = noisy;
    left.at<uint8_t>(row, 110 + i) = noisy;
  }
  SalientSadOptions options;
  options.max_disparity_px = 31;
  const std::vector<Corner> corners = {{100, row, 1.0f}, {110, row, 1.0f}};
  StereoHypotheses out;
  ASSERT_TRUE(matchSalient(toImageU8(left), toImageU8(right), corners, options, &out).isOk());
  ASSERT_EQ(out.points.size(), 2u);
  const DisparityHypothesis* a = best(out, out.points[0]);
  const DisparityHypothesis* b = best(out, out.points[1]);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  EXPECT_NEAR(a->d_px, 5.0, kTruthTolPx);
  EXPECT_GT(a->cost, 0.0f);
  EXPECT_FALSE(a->lr_consistent);
  EXPECT_NEAR(b->d_px, 15.0, kTruthTolPx);
  EXPECT_EQ(b->cost, 0.0f);
  EXPECT_TRUE(b->lr_consistent);

  options.lr_check = false;
  ASSERT_TRUE(matchSalient(toImageU8(left), toImageU8(right), corners, options, &out).isOk());
  for (const DisparityHypothesis& h : out.hypotheses) EXPECT_FALSE(h.lr_consistent);
}

TEST(SalientSad, RowToleranceFindsMatchOneRowOff) {
  constexpr int kD = 9;
  const cv::Mat tex = randomTexture(400, 140, 51);
  // right(u - 9, v + 1) = left(u, v): the right camera sits one row low.
  const StereoPair pair = shiftedPair(tex, 320, 120, kD, 1);
  const std::vector<Corner> corners = gridCorners(80, 310, 5, 115, 7);
  SalientSadOptions options;
  StereoHypotheses strict;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &strict).isOk());
  options.row_tolerance_px = 1;
  StereoHypotheses tolerant;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &tolerant).isOk());
  ASSERT_EQ(strict.points.size(), tolerant.points.size());
  expectWellFormed(tolerant, options.max_hypotheses);
  for (size_t i = 0; i < tolerant.points.size(); ++i) {
    const DisparityHypothesis* t = best(tolerant, tolerant.points[i]);
    const DisparityHypothesis* s = best(strict, strict.points[i]);
    ASSERT_NE(t, nullptr);
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(t->row_offset_px, 1);
    EXPECT_NEAR(t->d_px, kD, kIntegerShiftTolPx);
    EXPECT_EQ(t->cost, 0.0f);
    EXPECT_TRUE(t->lr_consistent);
    EXPECT_GT(s->cost, 0.0f);  // without tolerance the exact match is out of reach
  }
}

/// Percent of points whose best hypothesis is within kTruthTolPx of d.
double bestCorrectPct(const StereoHypotheses& out, double d) {
  size_t ok = 0;
  for (const SalientPoint& p : out.points) {
    const DisparityHypothesis* h = best(out, p);
    if (h != nullptr && std::abs(h->d_px - d) <= kTruthTolPx) ++ok;
  }
  return 100.0 * static_cast<double>(ok) / static_cast<double>(out.points.size());
}

TEST(SalientSad, ZeroMeanHandlesGainAndOffset) {
  // A low-contrast texture seen by a right camera with 10 % more gain and +40 grey levels:
  // plain SAD pays the offset everywhere and drifts to wrong minima, zero-mean SAD does not.
  constexpr int kD = 12;
  constexpr double kGain = 1.1;
  constexpr double kOffset = 40.0;
  const cv::Mat tex = randomTexture(400, 140, 61, 70.0, 150.0);
  StereoPair pair = shiftedPair(tex, 320, 120, kD);
  for (uint8_t& px : pair.right.data) px = cv::saturate_cast<uint8_t>(kGain * px + kOffset);
  const std::vector<Corner> corners = gridCorners(80, 310, 5, 115, 5);
  // Plain SAD, then the sampling-insensitive cost (`twocam run`'s): zero-mean helps both.
  for (const bool interval : {false, true}) {
    double pct[2];  // plain, zero-mean
    for (const bool zero_mean : {false, true}) {
      SalientSadOptions options;
      options.birchfield_tomasi = interval;
      options.zero_mean = zero_mean;
      StereoHypotheses out;
      ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &out).isOk());
      pct[zero_mean ? 1 : 0] = bestCorrectPct(out, kD);
    }
    std::printf("[ gain/offset ] %s: best within 1 px: plain %.1f %%, zero-mean %.1f %%\n",
                interval ? "Birchfield-Tomasi" : "SAD",
                pct[0],
                pct[1]);
    EXPECT_GE(pct[1], 99.0) << "interval " << interval;
    EXPECT_LT(pct[0], pct[1] - 10.0) << "interval " << interval;
  }
}

TEST(SalientSad, SkipsCornersOutsideTheWindowAndReusesCapacity) {
  const cv::Mat tex = randomTexture(300, 80, 71);
  const StereoPair pair = shiftedPair(tex, 200, 60, 6);
  SalientSadOptions options;
  options.min_disparity_px = 10;
  options.max_disparity_px = 40;
  options.shiftable_windows = false;
  // (4, 5): window leaves the image; (14, 5): u - h = 9 < 10, no disparity fits;
  // (199, 5) and (100, 60): outside; (-3, -3): outside; (30, 5): searched up to d = 25.
  const std::vector<Corner> corners = {
      {4, 5, 1.0f}, {14, 5, 1.0f}, {199, 5, 1.0f}, {100, 60, 1.0f}, {-3, -3, 1.0f}, {30, 5, 1.0f}};
  StereoHypotheses out;
  out.hypotheses.reserve(1000);
  const DisparityHypothesis* storage = out.hypotheses.data();
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &out).isOk());
  ASSERT_EQ(out.points.size(), 2u);
  EXPECT_EQ(out.points[0].corner.u_px, 14);
  EXPECT_EQ(out.points[0].num_hypotheses, 0u);
  EXPECT_EQ(out.points[1].corner.u_px, 30);
  EXPECT_GE(out.points[1].num_hypotheses, 1u);
  for (const DisparityHypothesis& h : out.hypotheses) {
    EXPECT_GE(h.d_px, options.min_disparity_px - 0.5f);
    EXPECT_LE(h.d_px, 25.5f);
  }
  EXPECT_EQ(out.hypotheses.data(), storage);  // capacity reused, not reallocated
  // The window starting at u reaches further: d <= u for (14, 5) and (30, 5).
  options.shiftable_windows = true;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &out).isOk());
  ASSERT_EQ(out.points.size(), 2u);
  EXPECT_GE(out.points[0].num_hypotheses, 1u);
  for (const DisparityHypothesis& h : out.hypotheses) {
    EXPECT_LE(h.d_px, static_cast<float>(out.points[h.point_index].corner.u_px) + 0.5f);
  }
  EXPECT_EQ(out.hypotheses.data(), storage);
  // A second call clears the first's results.
  ASSERT_TRUE(matchSalient(pair.left, pair.right, {}, options, &out).isOk());
  EXPECT_TRUE(out.points.empty());
  EXPECT_TRUE(out.hypotheses.empty());
}

TEST(SalientSad, CostGateDropsWeakHypotheses) {
  const cv::Mat tex = randomTexture(400, 140, 81);
  StereoPair pair = shiftedPair(tex, 320, 120, 7);
  std::mt19937 rng(82);
  std::normal_distribution<double> noise(0.0, 6.0);
  for (uint8_t& px : pair.right.data) px = cv::saturate_cast<uint8_t>(px + noise(rng));
  const std::vector<Corner> corners = gridCorners(80, 310, 5, 115, 9);
  SalientSadOptions options;
  StereoHypotheses open;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &open).isOk());
  options.max_cost_per_px = 2.0f;  // below the noise's mean absolute difference (~6.8)
  StereoHypotheses gated;
  ASSERT_TRUE(matchSalient(pair.left, pair.right, corners, options, &gated).isOk());
  ASSERT_EQ(open.points.size(), gated.points.size());
  EXPECT_FALSE(open.hypotheses.empty());
  for (const DisparityHypothesis& h : gated.hypotheses) {
    EXPECT_LE(h.cost, options.max_cost_per_px * options.window_width_px);
  }
  EXPECT_LT(gated.hypotheses.size(), open.hypotheses.size() / 2);
}
TEST(ConfidentBest, AcceptsOnlyAnUncontestedConsistentBest) {
  StereoHypotheses hyps;
  auto point = [&hyps](std::vector<std::pair<float, bool>> list) {
    SalientPoint p;
    p.first_hypothesis = static_cast<uint32_t>(hyps.hypotheses.size());
    p.num_hypotheses = static_cast<uint32_t>(list.size());
    for (const auto& [d, lr] : list) {
      DisparityHypothesis h;
      h.d_px = d;
      h.lr_consistent = lr;
      hyps.hypotheses.push_back(h);
    }
    hyps.points.push_back(p);
  };
  point({});                              // no hypotheses
  point({{7.0f, false}, {12.0f, true}});  // best inconsistent
  point({{7.0f, true}, {12.0f, true}});   // consistent rival at another depth
  point({{7.0f, true}, {7.9f, true}});    // consistent rival, same answer within 1 px
  point({{7.0f, true}, {12.0f, false}, {3.0f, false}});  // rivals inconsistent
  EXPECT_EQ(confidentBest(hyps, hyps.points[0]), nullptr);
  EXPECT_EQ(confidentBest(hyps, hyps.points[1]), nullptr);
  EXPECT_EQ(confidentBest(hyps, hyps.points[2]), nullptr);
  EXPECT_EQ(confidentBest(hyps, hyps.points[3]), &hyps.hypotheses[4]);
  EXPECT_EQ(confidentBest(hyps, hyps.points[3], 0.5f), nullptr);
  EXPECT_EQ(confidentBest(hyps, hyps.points[4]), &hyps.hypotheses[6]);
}

TEST(ConfidentBestDeathTest, PointOfAnotherFrameAborts) {
  StereoHypotheses hyps;
  SalientPoint p;
  p.first_hypothesis = 3;
  p.num_hypotheses = 2;
  EXPECT_DEATH((void)confidentBest(hyps, p), "outside");
}
// ---------------------------------------------------------------------------------------------
// Middlebury: recall_at_k and single-best bad1 against ground truth (METRICS.md).

struct MiddleburyScene {
  std::string name;
  std::string left_file;
  std::string right_file;
  std::string gt_file;
  double gt_scale;  // d = value / gt_scale, 0 unknown
  int max_disparity_px;
};

/// Middlebury's evaluation masks from the left ground truth alone. valid: GT known (non-zero).
/// non-occluded: also seen by the right camera, i.e. u - d >= 0 and no pixel further right
/// on the row lands at or left of it in the right view (that nearer surface hides it).
struct GtMasks {
  cv::Mat valid;
  cv::Mat non_occluded;
};

GtMasks gtMasks(const cv::Mat& gt, double gt_scale) {
  GtMasks masks{cv::Mat(gt.size(), CV_8U, cv::Scalar(0)), cv::Mat(gt.size(), CV_8U, cv::Scalar(0))};
  for (int v = 0; v < gt.rows; ++v) {
    double leftmost_landing = 1e9;  // min over valid u2 > u of u2 - d(u2)
    for (int u = gt.cols - 1; u >= 0; --u) {
      const uint8_t raw = gt.at<uint8_t>(v, u);
      if (raw == 0) continue;
      const double d = raw / gt_scale;
      masks.valid.at<uint8_t>(v, u) = 1;
      const bool hidden = leftmost_landing <= u - d - 0.5;
      if (u - d >= 0.0 && !hidden) masks.non_occluded.at<uint8_t>(v, u) = 1;
      leftmost_landing = std::min(leftmost_landing, u - d);
    }
  }
  return masks;
}

struct SalientMetrics {
  size_t points = 0;
  double recall_at_k_pct = 0.0;
  double recall_at_1_pct = 0.0;
  size_t lr_consistent = 0;
  double lr_consistent_bad1_pct = 0.0;
  size_t confident = 0;
  double confident_bad1_pct = 0.0;
  double mean_hypotheses = 0.0;
};

/// METRICS.md salient mode over the points inside `mask`: recall_at_k (k = the matcher's K),
/// recall of the best alone, and single-best bad1 among points whose best passed the
/// right-to-left check (lr_consistent) and among those confidentBest() accepts.
SalientMetrics evaluate(const StereoHypotheses& out,
                        const cv::Mat& gt,
                        double gt_scale,
                        const cv::Mat& mask) {
  SalientMetrics m;
  size_t recalled = 0;
  size_t recalled1 = 0;
  size_t lr_bad = 0;
  size_t confident_bad = 0;
  size_t hyps = 0;
  for (const SalientPoint& p : out.points) {
    if (mask.at<uint8_t>(p.corner.v_px, p.corner.u_px) == 0) continue;
    const double d_gt = gt.at<uint8_t>(p.corner.v_px, p.corner.u_px) / gt_scale;
    ++m.points;
    hyps += p.num_hypotheses;
    if (anyWithin(out, p, d_gt, kTruthTolPx)) ++recalled;
    const DisparityHypothesis* h = best(out, p);
    const bool best_bad = h == nullptr || std::abs(h->d_px - d_gt) > kTruthTolPx;
    if (!best_bad) ++recalled1;
    if (h != nullptr && h->lr_consistent) {
      ++m.lr_consistent;
      if (best_bad) ++lr_bad;
    }
    if (confidentBest(out, p) != nullptr) {
      ++m.confident;
      if (best_bad) ++confident_bad;
    }
  }
  auto pct = [](size_t num, size_t den) {
    return den == 0 ? 0.0 : 100.0 * static_cast<double>(num) / static_cast<double>(den);
  };
  m.recall_at_k_pct = pct(recalled, m.points);
  m.recall_at_1_pct = pct(recalled1, m.points);
  m.lr_consistent_bad1_pct = pct(lr_bad, m.lr_consistent);
  m.confident_bad1_pct = pct(confident_bad, m.confident);
  m.mean_hypotheses = m.points == 0 ? 0.0 : static_cast<double>(hyps) / m.points;
  return m;
}

std::vector<Corner> harrisCorners(const cv::Mat& grey, int max_corners) {
  std::vector<cv::Point2f> pts;
  cv::goodFeaturesToTrack(grey, pts, max_corners, 0.01, 3.0, cv::noArray(), 3, true, 0.04);
  std::vector<Corner> corners;
  corners.reserve(pts.size());
  for (const cv::Point2f& p : pts) {
    corners.push_back(
        {static_cast<int>(std::lround(p.x)), static_cast<int>(std::lround(p.y)), 1.0f});
  }
  return corners;
}

void printMetrics(const std::string& label, const SalientMetrics& m) {
  std::printf(
      "[ %-37s ] pts %4zu  recall@4 %5.1f %%  recall@1 %5.1f %%  bad1: lr-consistent best "
      "%4.1f %% (%zu), confident best %4.1f %% (%zu)  hyps/pt %.2f\n",
      label.c_str(),
      m.points,
      m.recall_at_k_pct,
      m.recall_at_1_pct,
      m.lr_consistent_bad1_pct,
      m.lr_consistent,
      m.confident_bad1_pct,
      m.confident,
      m.mean_hypotheses);
}

class MiddleburyTest : public ::testing::TestWithParam<MiddleburyScene> {};

TEST_P(MiddleburyTest, RecallAndConfidentBad1MeetTargets) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const MiddleburyScene& scene = GetParam();
  const std::string dir = data + "/middlebury/" + scene.name + "/";
  ImageU8 left;
  ImageU8 right;
  ASSERT_TRUE(loadGrey(dir + scene.left_file, &left).isOk());
  ASSERT_TRUE(loadGrey(dir + scene.right_file, &right).isOk());
  const cv::Mat gt = cv::imread(dir + scene.gt_file, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(gt.empty());
  ASSERT_EQ(gt.type(), CV_8U);
  ASSERT_EQ(gt.cols, left.width);
  const GtMasks masks = gtMasks(gt, scene.gt_scale);
  const std::vector<Corner> corners = harrisCorners(asMat(left), 2000);
  ASSERT_GT(corners.size(), 200u);

  // Defaults except the scene's disparity range.
  SalientSadOptions options;
  options.max_disparity_px = scene.max_disparity_px;
  StereoHypotheses out;
  ASSERT_TRUE(matchSalient(left, right, corners, options, &out).isOk());
  expectWellFormed(out, options.max_hypotheses);
  const SalientMetrics all = evaluate(out, gt, scene.gt_scale, masks.valid);
  const SalientMetrics nonocc = evaluate(out, gt, scene.gt_scale, masks.non_occluded);
  printMetrics(scene.name + " SAD, all", all);
  printMetrics(scene.name + " SAD, non-occluded", nonocc);
  EXPECT_GE(nonocc.recall_at_k_pct, kMinRecallAt4Pct);
  EXPECT_LE(nonocc.confident_bad1_pct, kMaxConfidentBad1Pct);
  EXPECT_GT(nonocc.confident, nonocc.points * 3 / 4);  // the checks must not reject most
  EXPECT_GE(all.recall_at_k_pct, kMinRecallAt4Pct - 5.0);

  // The centred window alone (Paper B as published), for comparison.
  SalientSadOptions centred = options;
  centred.shiftable_windows = false;
  ASSERT_TRUE(matchSalient(left, right, corners, centred, &out).isOk());
  const SalientMetrics centred_nonocc = evaluate(out, gt, scene.gt_scale, masks.non_occluded);
  printMetrics(scene.name + " SAD centred only, non-occ.", centred_nonocc);
  EXPECT_GE(nonocc.recall_at_k_pct, centred_nonocc.recall_at_k_pct);

  // The sampling-insensitive cost `twocam run` uses.
  SalientSadOptions bt = options;
  bt.birchfield_tomasi = true;
  ASSERT_TRUE(matchSalient(left, right, corners, bt, &out).isOk());
  expectWellFormed(out, bt.max_hypotheses);
  const SalientMetrics bt_nonocc = evaluate(out, gt, scene.gt_scale, masks.non_occluded);
  printMetrics(scene.name + " Birchfield-Tomasi, non-occluded", bt_nonocc);
  EXPECT_GE(bt_nonocc.recall_at_k_pct, kMinRecallAt4Pct);
  EXPECT_LE(bt_nonocc.confident_bad1_pct, kMaxConfidentBad1Pct);

  // Zero-mean SAD, on the pair as is and with a radiometric difference between the views.
  options.zero_mean = true;
  ASSERT_TRUE(matchSalient(left, right, corners, options, &out).isOk());
  const SalientMetrics zm = evaluate(out, gt, scene.gt_scale, masks.non_occluded);
  printMetrics(scene.name + " zero-mean SAD, non-occ.", zm);
  EXPECT_GE(zm.recall_at_k_pct, kMinRecallAt4Pct - 5.0);

  ImageU8 right_radiometric = right;
  for (uint8_t& px : right_radiometric.data) px = cv::saturate_cast<uint8_t>(0.85 * px + 30.0);
  options.zero_mean = false;
  ASSERT_TRUE(matchSalient(left, right_radiometric, corners, options, &out).isOk());
  const SalientMetrics plain_rad = evaluate(out, gt, scene.gt_scale, masks.non_occluded);
  printMetrics(scene.name + " SAD, right 0.85x+30, non-occ.", plain_rad);
  options.zero_mean = true;
  ASSERT_TRUE(matchSalient(left, right_radiometric, corners, options, &out).isOk());
  const SalientMetrics zm_rad = evaluate(out, gt, scene.gt_scale, masks.non_occluded);
  printMetrics(scene.name + " ZSAD, right 0.85x+30, non-occ.", zm_rad);
  EXPECT_GT(zm_rad.recall_at_1_pct, plain_rad.recall_at_1_pct);
  EXPECT_GE(zm_rad.recall_at_k_pct, kMinRecallAt4Pct - 5.0);

  // Paper A: pair with the right image's corners from the same detector.
  options.zero_mean = false;
  const std::vector<Corner> right_corners = harrisCorners(asMat(right), 2000);
  for (int m_rows : {0, 1}) {
    options.row_tolerance_px = m_rows;
    ASSERT_TRUE(pairCorners(left, right, corners, right_corners, options, &out).isOk());
    expectWellFormed(out, options.max_hypotheses);
    const SalientMetrics pc = evaluate(out, gt, scene.gt_scale, masks.non_occluded);
    printMetrics(scene.name + " Paper A pairs m=" + std::to_string(m_rows) + ", non-occ.", pc);
    EXPECT_GT(pc.recall_at_k_pct, 50.0);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Scenes,
    MiddleburyTest,
    ::testing::Values(MiddleburyScene{"tsukuba", "im3.png", "im4.png", "disp3.pgm", 16.0, 16},
                      MiddleburyScene{"venus", "im2.png", "im6.png", "disp2.pgm", 8.0, 20}),
    [](const ::testing::TestParamInfo<MiddleburyScene>& scene_info) {
      return scene_info.param.name;
    });

}  // namespace
}  // namespace twocam::frontend
