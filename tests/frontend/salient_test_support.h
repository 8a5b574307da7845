#pragma once
// Shared fixtures of the salient-matcher tests (salient_sad_test, sad_kernels_test,
// row_support_test, corner_pairing_test): seeded textures, shifted pairs, corner grids, the
// invariants of a StereoHypotheses, and the tolerances they share.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "common/features.h"
#include "common/image.h"
#include "frontend/cv_interop.h"

namespace twocam::frontend {

// Tolerances, each with its reason.
/// Noise-free integer shift: the parabola through a V-shaped SAD valley with a 0 at the truth
/// moves the estimate by the asymmetry of the two neighbours only.
constexpr double kIntegerShiftTolPx = 0.35;
/// Sub-pixel shift of a band-limited texture, parabola fit on SAD (pixel-locking bias of the
/// parabola on a V-shaped SAD curve, measured up to 0.21 px; 8-bit quantisation adds a little).
constexpr double kSubpixelMeanAbsTolPx = 0.15;
constexpr double kSubpixelMaxAbsTolPx = 0.3;
/// Share of points whose best hypothesis is the truth on that texture: at half-pixel shifts
/// random look-alikes win some points (measured 93-100 %).
constexpr double kMinSubpixelBestCorrectPct = 85.0;
/// A hypothesis is "true" within 1 px of the ground truth (METRICS.md recall_at_k, bad1).
constexpr double kTruthTolPx = 1.0;
/// Targets from the issue for Middlebury Tsukuba and Venus, over non-occluded points.
constexpr double kMinRecallAt4Pct = 95.0;
constexpr double kMaxConfidentBad1Pct = 5.0;
/// Birchfield-Tomasi on sharp bars at half-pixel shifts: its best cost is what the one-sided
/// interval cannot absorb (rounding, bars narrower than the interval); measured 0.19 of SAD's
/// (8.6 against 46.1 grey levels per window).
constexpr double kMaxHalfPixelCostRatio = 0.5;

struct StereoPair {
  ImageU8 left;
  ImageU8 right;
};

/// Seeded texture with features a few px wide (blurred uniform noise stretched to [lo, hi]).
inline cv::Mat randomTexture(
    int width, int height, uint64_t seed, double lo = 0.0, double hi = 255.0) {
  cv::RNG rng(seed);
  cv::Mat noise(height, width, CV_32F);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
  cv::normalize(noise, noise, lo, hi, cv::NORM_MINMAX);
  cv::Mat out;
  noise.convertTo(out, CV_8U);
  return out;
}

/// Crops of T such that right(u - d, v + dv) = left(u, v): the right view of a fronto-parallel
/// plane at disparity d, dv rows low (T is wider and taller than the images).
inline StereoPair shiftedPair(const cv::Mat& tex, int width, int height, int d, int dv = 0) {
  cv::Mat left = tex(cv::Rect(0, 8, width, height)).clone();
  cv::Mat right = tex(cv::Rect(d, 8 - dv, width, height)).clone();
  return {toImageU8(left), toImageU8(right)};
}

inline std::vector<Corner> gridCorners(int u0, int u1, int v0, int v1, int step) {
  std::vector<Corner> corners;
  for (int v = v0; v < v1; v += step) {
    for (int u = u0; u < u1; u += step) corners.push_back({u, v, 1.0f});
  }
  return corners;
}

inline const DisparityHypothesis* best(const StereoHypotheses& hyps, const SalientPoint& p) {
  return p.num_hypotheses == 0 ? nullptr : &hyps.hypotheses[p.first_hypothesis];
}

inline bool anyWithin(const StereoHypotheses& hyps, const SalientPoint& p, double d, double tol) {
  for (uint32_t k = 0; k < p.num_hypotheses; ++k) {
    if (std::abs(hyps.hypotheses[p.first_hypothesis + k].d_px - d) <= tol) return true;
  }
  return false;
}

/// Invariants of any StereoHypotheses the matchers produce.
inline void expectWellFormed(const StereoHypotheses& hyps, int max_k) {
  uint32_t next = 0;
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const SalientPoint& p = hyps.points[i];
    ASSERT_EQ(p.first_hypothesis, next);
    ASSERT_LE(p.num_hypotheses, static_cast<uint32_t>(max_k));
    for (uint32_t k = 0; k < p.num_hypotheses; ++k) {
      const DisparityHypothesis& h = hyps.hypotheses[p.first_hypothesis + k];
      EXPECT_EQ(h.point_index, i);
      EXPECT_EQ(h.rank, k);
      if (k > 0) {
        EXPECT_GE(h.cost, hyps.hypotheses[p.first_hypothesis + k - 1].cost);
      }
    }
    next += p.num_hypotheses;
  }
  EXPECT_EQ(next, hyps.hypotheses.size());
}

}  // namespace twocam::frontend
