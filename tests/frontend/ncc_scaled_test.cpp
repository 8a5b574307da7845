#include "frontend/ncc_scaled.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"
#include "support/test_paths.h"

namespace twocam::frontend {
namespace {

// Sub-pixel search steps of 1/10 px plus 8-bit rounding of the rendered pairs.
constexpr double kSubpixelTolPx = 0.15;
// A scaled window's estimate on a fronto-parallel plane, pulled towards the integer disparity.
constexpr double kScaledSubpixelTolPx = 0.35;
// Float sums in a different order (ring of rows against one window walk).
constexpr float kNccTol = 1e-4f;

/// A smooth random texture that can be evaluated anywhere: a sum of plane waves with seeded
/// frequencies (0.15..0.7 rad/px along the row, a camera-blurred texture whose 1/sqrt(2)
/// compression stays well below Nyquist)
/// and phases, scaled to about 30..225 grey levels.
class Texture {
 public:
  explicit Texture(uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> wx(0.15, 0.7);
    std::uniform_real_distribution<double> wy(-0.8, 0.8);
    std::uniform_real_distribution<double> phase(0.0, 6.283185307179586);
    for (int k = 0; k < kWaves; ++k) waves_[k] = {wx(rng), wy(rng), phase(rng)};
  }
  [[nodiscard]] double operator()(double x, double y) const {
    double s = 0.0;
    for (const Wave& w : waves_) s += std::sin(w.wx * x + w.wy * y + w.phase);
    return 128.0 + 95.0 * s / std::sqrt(static_cast<double>(kWaves) / 2.0) / 2.0;
  }

 private:
  static constexpr int kWaves = 16;
  struct Wave {
    double wx = 0.0, wy = 0.0, phase = 0.0;
  };
  Wave waves_[kWaves];
};

uint8_t toGrey(double value) {
  return static_cast<uint8_t>(std::clamp(std::lround(value), 0L, 255L));
}

struct Pair {
  ImageU8 left;
  ImageU8 right;
  ImageF32 truth;  // left-view disparity [px], < 0 = none (occluded)
};

/// A plane d(u) = d0 + slope * u seen by both cameras: L(u, y) = T(u, y) and
/// R(x, y) = T(u(x), y) with x = u - d(u), so a left window maps onto right samples spaced
/// (1 - slope) apart: slope 1 - 1/sqrt(2) is the matcher's scale 1/sqrt(2), 1 - sqrt(2) its
/// sqrt(2). slope 0 is a fronto-parallel plane at d0 (any real value).
Pair slantedPair(int width, int height, double d0, double slope, uint32_t seed) {
  const Texture tex(seed);
  Pair p{ImageU8(width, height), ImageU8(width, height), ImageF32(width, height)};
  for (int y = 0; y < height; ++y) {
    for (int u = 0; u < width; ++u) {
      p.left(u, y) = toGrey(tex(u, y));
      // No truth where the match falls outside the right image (or within 3 px of its edge).
      const double x = u - (d0 + slope * u);
      p.truth(u, y) = x >= 3.0 && x <= width - 4.0 ? static_cast<float>(d0 + slope * u) : -1.0f;
      p.right(u, y) = toGrey(tex((u + d0) / (1.0 - slope), y));
    }
  }
  return p;
}

/// Fronto-parallel step: background at d_far left of column `edge`, foreground at d_near from
/// it on; background pixels hidden from the right camera have no truth.
Pair stepPair(int width, int height, int edge, int d_far, int d_near, uint32_t seed) {
  const Texture far(seed);
  const Texture near(seed + 1);
  Pair p{ImageU8(width, height), ImageU8(width, height), ImageF32(width, height)};
  for (int y = 0; y < height; ++y) {
    for (int u = 0; u < width; ++u) {
      const bool fg = u >= edge;
      p.left(u, y) = toGrey(fg ? near(u, y) : far(u, y));
      const bool occluded = !fg && u - d_far >= edge - d_near;
      p.truth(u, y) = occluded ? -1.0f : static_cast<float>(fg ? d_near : d_far);
      const bool right_fg = u >= edge - d_near;
      p.right(u, y) = toGrey(right_fg ? near(u + d_near, y) : far(u + d_far, y));
    }
  }
  return p;
}

NccScaledOptions matchOnly(int max_d) {
  NccScaledOptions o;
  o.max_disparity_px = max_d;
  o.median_rejection = false;
  o.bilateral = false;
  return o;
}

struct Score {
  int evaluated = 0;
  int estimated = 0;
  int within = 0;  // |err| <= tol
  double abs_err_sum = 0.0;
  [[nodiscard]] double avgerr() const { return abs_err_sum / std::max(1, estimated); }
  [[nodiscard]] double withinFraction() const {
    return static_cast<double>(within) / std::max(1, evaluated);
  }
};

Score score(const ImageF32& d, const ImageF32& truth, int u0, int u1, int v0, int v1, double tol) {
  Score s;
  for (int v = v0; v < v1; ++v) {
    for (int u = u0; u < u1; ++u) {
      if (truth(u, v) < 0.0f) continue;
      ++s.evaluated;
      if (d(u, v) < 0.0f) continue;
      ++s.estimated;
      const double err = std::abs(d(u, v) - truth(u, v));
      s.abs_err_sum += err;
      s.within += err <= tol ? 1 : 0;
    }
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// Options and bad input

TEST(NccScaledOptions, DefaultsAreThePapersAndValid) {
  const NccScaledOptions o;
  EXPECT_TRUE(o.validate().isOk()) << o.validate().message();
  EXPECT_EQ(o.window_size_px, 5);
  EXPECT_FLOAT_EQ(o.ncc_threshold, 0.5f);
  EXPECT_EQ(o.subpixel_steps, 10);
  EXPECT_EQ(o.median_size_px, 15);
  EXPECT_EQ(o.bilateral_size_px, 15);
  EXPECT_FLOAT_EQ(kNccScales[0] * kNccScales[2], 1.0f);
}

TEST(NccScaledOptions, ValidateNamesTheBrokenOption) {
  struct Case {
    const char* key;
    void (*break_it)(NccScaledOptions*);
  };
  const Case cases[] = {
      {"window_size_px", [](NccScaledOptions* o) { o->window_size_px = 4; }},
      {"window_size_px", [](NccScaledOptions* o) { o->window_size_px = 33; }},
      {"min_disparity_px", [](NccScaledOptions* o) { o->min_disparity_px = -1; }},
      {"max_disparity_px", [](NccScaledOptions* o) { o->max_disparity_px = -1; }},
      {"ncc_threshold", [](NccScaledOptions* o) { o->ncc_threshold = 1.5f; }},
      {"ncc_threshold", [](NccScaledOptions* o) { o->ncc_threshold = std::nanf(""); }},
      {"min_window_std", [](NccScaledOptions* o) { o->min_window_std = -1.0f; }},
      {"subpixel_steps", [](NccScaledOptions* o) { o->subpixel_steps = 65; }},
      {"median_size_px", [](NccScaledOptions* o) { o->median_size_px = 14; }},
      {"median_rejection_px", [](NccScaledOptions* o) { o->median_rejection_px = 0.0f; }},
      {"bilateral_size_px", [](NccScaledOptions* o) { o->bilateral_size_px = 1; }},
      {"bilateral_sigma_space_px", [](NccScaledOptions* o) { o->bilateral_sigma_space_px = 0.0f; }},
      {"bilateral_sigma_range_px",
       [](NccScaledOptions* o) { o->bilateral_sigma_range_px = -2.0f; }},
      {"max_hypotheses", [](NccScaledOptions* o) { o->max_hypotheses = 0; }},
      {"hypothesis_margin", [](NccScaledOptions* o) { o->hypothesis_margin = 3.0f; }},
      {"lr_tolerance_px", [](NccScaledOptions* o) { o->lr_tolerance_px = -1; }},
  };
  for (const Case& c : cases) {
    NccScaledOptions o;
    c.break_it(&o);
    const Status s = o.validate();
    ASSERT_FALSE(s.isOk()) << c.key;
    EXPECT_NE(s.message().find(c.key), std::string::npos) << s.message();
  }
}

TEST(NccScaledMatcher, BadInputIsAnErrorAndLeavesTheMapAlone) {
  const Pair p = slantedPair(64, 24, 4.0, 0.0, 1);
  NccScaledOptions o = matchOnly(16);
  ImageF32 d(3, 3, 7.0f);
  NccScaledMatcher m;
  EXPECT_FALSE(m.compute(ImageU8(), p.right, o, &d).isOk());
  EXPECT_FALSE(m.compute(p.left, ImageU8(32, 24), o, &d).isOk());
  EXPECT_FALSE(m.compute(p.left, p.right, o, nullptr).isOk());
  o.max_disparity_px = 64;
  Status s = m.compute(p.left, p.right, o, &d);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("max_disparity_px"), std::string::npos) << s.message();
  o = matchOnly(16);
  o.window_size_px = 6;
  s = m.compute(p.left, p.right, o, &d);
  EXPECT_NE(s.message().find("window_size_px = 6"), std::string::npos) << s.message();
  o = matchOnly(2);
  o.window_size_px = 31;
  EXPECT_FALSE(m.compute(p.left, p.right, o, &d).isOk()) << "window taller than the image";
  EXPECT_EQ(d.data, std::vector<float>(9, 7.0f));
  StereoHypotheses hyps;
  hyps.points.resize(2);
  EXPECT_FALSE(matchNccSalient(p.left, ImageU8(), {{10, 10, 1.0f}}, matchOnly(16), &hyps).isOk());
  EXPECT_FALSE(matchNccSalient(p.left, p.right, {{10, 10, 1.0f}}, matchOnly(16), nullptr).isOk());
  EXPECT_EQ(hyps.points.size(), 2u) << "errors leave out untouched";
}

// ---------------------------------------------------------------------------------------------
// Dense matching

TEST(NccScaledMatcher, FrontoParallelSubpixelShiftIsFoundToATenthOfAPixel) {
  constexpr double kTrueD = 6.3;
  const Pair p = slantedPair(120, 40, kTrueD, 0.0, 7);
  NccScaledMatcher m;
  ImageF32 d;
  ASSERT_TRUE(m.compute(p.left, p.right, matchOnly(16), &d).isOk());
  // Columns from 16 on, where the whole range can be searched. Where a scaled window wins on
  // this fronto-parallel plane (about 1 pixel in 10: on a smooth texture a 5x5 window is
  // nearly a ramp, and a stretched ramp correlates as well), its estimate is pulled 0.1-0.3 px
  // towards the integer disparity (its samples are all interpolated, the square window's at
  // an integer shift are not); measured 89.7 % within 0.15 px, avgerr 0.031 px.
  const Score s = score(d, p.truth, 16, 118, 2, 38, kSubpixelTolPx);
  EXPECT_GE(s.withinFraction(), 0.85);
  EXPECT_LE(s.avgerr(), 0.05);
  // The square window wins on a fronto-parallel surface.
  int square = 0;
  int total = 0;
  for (int v = 2; v < 38; ++v) {
    for (int u = 16; u < 118; ++u) {
      if (m.scaleIndex()(u, v) == kNoScale) continue;
      ++total;
      square += m.scaleIndex()(u, v) == 1 ? 1 : 0;
    }
  }
  EXPECT_GE(square, 0.85 * total);
  // The square window alone finds the shift everywhere (measured: all within 0.15 px, avgerr
  // 0.001 px).
  NccScaledOptions o = matchOnly(16);
  o.scaled_windows = false;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &d).isOk());
  const Score sq = score(d, p.truth, 16, 118, 2, 38, kSubpixelTolPx);
  EXPECT_GE(sq.withinFraction(), 0.99);
  EXPECT_LE(sq.avgerr(), 0.01);
}

TEST(NccScaledMatcher, SlantedPlanesPickTheMatchingScaleAndBeatTheSquareWindow) {
  struct Case {
    double d0;
    double slope;
    int expected_scale;
  };
  const Case cases[] = {{6.0, 1.0 - 1.0 / std::sqrt(2.0), 0}, {88.0, 1.0 - std::sqrt(2.0), 2}};
  for (const Case& c : cases) {
    const Pair p = slantedPair(200, 40, c.d0, c.slope, 11);
    NccScaledOptions o = matchOnly(96);
    NccScaledMatcher m;
    ImageF32 scaled;
    ImageF32 square;
    ASSERT_TRUE(m.compute(p.left, p.right, o, &scaled).isOk());
    int hits = 0;
    int total = 0;
    for (int v = 2; v < 38; ++v) {
      for (int u = 8; u < 192; ++u) {
        if (m.scaleIndex()(u, v) == kNoScale) continue;
        ++total;
        hits += m.scaleIndex()(u, v) == c.expected_scale ? 1 : 0;
      }
    }
    o.scaled_windows = false;
    ASSERT_TRUE(m.compute(p.left, p.right, o, &square).isOk());
    const Score s_scaled = score(scaled, p.truth, 8, 192, 2, 38, kSubpixelTolPx);
    const Score s_square = score(square, p.truth, 8, 192, 2, 38, kSubpixelTolPx);
    EXPECT_GE(hits, 0.8 * total) << "slope " << c.slope;

    // Measured: scale hits 90 % / 81 %, within 0.15 px 91 % / 96 % against 67 % / 34 % for
    // the square window, avgerr 1.77 / 0.13 px against 3.34 / 1.04 px.
    EXPECT_GE(s_scaled.withinFraction(), 0.85) << "slope " << c.slope;
    EXPECT_LT(s_scaled.avgerr(), s_square.avgerr()) << "slope " << c.slope;
    EXPECT_GT(s_scaled.withinFraction(), s_square.withinFraction()) << "slope " << c.slope;
  }
}

TEST(NccScaledMatcher, EstimatesKeepTheThresholdAndTheNccIsThatOfTheWindows) {
  const Pair p = slantedPair(100, 30, 5.0, 0.1, 3);
  NccScaledOptions o = matchOnly(20);
  o.subpixel_steps = 0;
  NccScaledMatcher m;
  ImageF32 d;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &d).isOk());
  int checked = 0;
  for (int v = 2; v < 28; v += 3) {
    for (int u = 2; u < 98; u += 5) {
      if (d(u, v) < 0.0f) continue;
      EXPECT_GE(m.ncc()(u, v), o.ncc_threshold);
      const float direct = nccAt(p.left,
                                 p.right,
                                 u,
                                 v,
                                 u - static_cast<double>(d(u, v)),
                                 kNccScales[m.scaleIndex()(u, v)],
                                 o.window_size_px,
                                 o.min_window_std);
      EXPECT_NEAR(direct, m.ncc()(u, v), kNccTol) << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 100);
}

TEST(NccScaledMatcher, UncorrelatedViewsGiveNoEstimateAboveAHighThreshold) {
  std::mt19937 rng(21);
  std::uniform_int_distribution<int> grey(0, 255);
  ImageU8 a(80, 30);
  ImageU8 b(80, 30);
  for (uint8_t& x : a.data) x = static_cast<uint8_t>(grey(rng));
  for (uint8_t& x : b.data) x = static_cast<uint8_t>(grey(rng));
  NccScaledOptions o = matchOnly(8);
  o.ncc_threshold = 0.9f;
  ImageF32 d;
  ASSERT_TRUE(computeNccScaledDisparity(a, b, o, &d).isOk());
  const auto estimates =
      std::count_if(d.data.begin(), d.data.end(), [](float x) { return x >= 0; });
  EXPECT_LE(estimates, static_cast<long>(d.data.size() / 100));
}

TEST(NccScaledMatcher, FlatWindowsHaveNoEstimate) {
  ImageU8 flat(40, 20, 90);
  ImageF32 d;
  ASSERT_TRUE(computeNccScaledDisparity(flat, flat, matchOnly(8), &d).isOk());
  EXPECT_TRUE(std::all_of(d.data.begin(), d.data.end(), [](float x) { return x < 0.0f; }));
}

TEST(NccScaledMatcher, FiltersRemoveStepOutliersAndKeepTheSurfaces) {
  const Pair p = stepPair(160, 48, 80, 4, 12, 5);
  NccScaledMatcher m;
  ImageF32 raw;
  ImageF32 filtered;
  ASSERT_TRUE(m.compute(p.left, p.right, matchOnly(20), &raw).isOk());
  NccScaledOptions o;
  o.max_disparity_px = 20;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &filtered).isOk());
  // Away from the edge both surfaces are found to sub-pixel accuracy.
  const Score far = score(filtered, p.truth, 22, 64, 8, 40, 0.5);
  const Score near = score(filtered, p.truth, 92, 150, 8, 40, 0.5);
  EXPECT_GE(far.withinFraction(), 0.97);
  EXPECT_GE(near.withinFraction(), 0.97);
  // Across the whole map the filters leave fewer estimates off by more than 1 px.
  auto wrong = [&](const ImageF32& d) {
    int n = 0;
    for (int v = 2; v < 46; ++v) {
      for (int u = 22; u < 158; ++u) {
        if (d(u, v) >= 0.0f && (p.truth(u, v) < 0.0f || std::abs(d(u, v) - p.truth(u, v)) > 1.0f))
          ++n;
      }
    }
    return n;
  };
  EXPECT_LT(wrong(filtered), wrong(raw));
}

TEST(NccScaledMatcher, ReuseGivesIdenticalOutput) {
  const Pair p = stepPair(120, 32, 60, 3, 9, 9);
  const Pair q = slantedPair(90, 20, 4.0, 0.2, 10);
  NccScaledOptions o;
  o.max_disparity_px = 16;
  NccScaledMatcher m;
  ImageF32 first;
  ImageF32 other;
  ImageF32 again;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &first).isOk());
  const ImageU8 first_scales = m.scaleIndex();
  ASSERT_TRUE(m.compute(q.left, q.right, o, &other).isOk());
  ASSERT_TRUE(m.compute(p.left, p.right, o, &again).isOk());
  EXPECT_EQ(first.data, again.data);
  EXPECT_EQ(first_scales.data, m.scaleIndex().data);
  ImageF32 fresh;
  ASSERT_TRUE(computeNccScaledDisparity(p.left, p.right, o, &fresh).isOk());
  EXPECT_EQ(first.data, fresh.data);
}

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

// ---------------------------------------------------------------------------------------------
// Middlebury Venus (shared data; skipped when absent): the target, sub-pixel accuracy
// on slanted planes better than dense 1-D SAD with its sub-pixel fit.

TEST(NccScaledMiddlebury, VenusSubpixelAccuracyBeatsDenseSad) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string dir = data + "/middlebury/venus";
  ImageU8 left, right, gt;
  ASSERT_TRUE(loadGrey(dir + "/im2.png", &left).isOk());
  ASSERT_TRUE(loadGrey(dir + "/im6.png", &right).isOk());
  ASSERT_TRUE(loadGrey(dir + "/disp2.pgm", &gt).isOk());
  ImageF32 truth(gt.width, gt.height);
  for (size_t i = 0; i < gt.data.size(); ++i) {
    truth.data[i] = gt.data[i] == 0 ? -1.0f : static_cast<float>(gt.data[i]) / 8.0f;
  }
  NccScaledOptions o;
  o.max_disparity_px = 20;
  ImageF32 ncc_d;
  ASSERT_TRUE(computeNccScaledDisparity(left, right, o, &ncc_d).isOk());
  DenseSadOptions sad;
  sad.max_disparity_px = 20;
  sad.subpixel = true;
  ImageF32 sad_d;
  ASSERT_TRUE(computeDenseDisparity(left, right, sad, &sad_d).isOk());
  const Score s_ncc = score(ncc_d, truth, 0, truth.width, 0, truth.height, 0.5);
  const Score s_sad = score(sad_d, truth, 0, truth.width, 0, truth.height, 0.5);
  // bad0.5 over all pixels with ground truth.
  const double bad05_ncc =
      100.0 * (s_ncc.estimated - s_ncc.within) / static_cast<double>(s_ncc.evaluated);
  const double bad05_sad =
      100.0 * (s_sad.estimated - s_sad.within) / static_cast<double>(s_sad.evaluated);
  EXPECT_LT(s_ncc.avgerr(), 0.5 * s_sad.avgerr());
  EXPECT_LT(bad05_ncc, 0.5 * bad05_sad);
  RecordProperty("ncc_avgerr", std::to_string(s_ncc.avgerr()));
  RecordProperty("sad_avgerr", std::to_string(s_sad.avgerr()));
}

}  // namespace
}  // namespace twocam::frontend
