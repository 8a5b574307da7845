#pragma once
/// "Support value" stereo matching (seed paper 004, a stereo system for micro-manipulation):
/// dense disparity maps and several-hypothesis matches at salient points of a rectified 8-bit
/// pair. docs/matchers/support_value.md describes the model, its options and its figures.
///
/// The paper's matching criterion (§2.1), for a left pixel p = (u, v) and a disparity d:
///  1. the local mean of each local support, m_l over the window around p in the left image,
///     m_r over the window around p - (d, 0) in the right image;
///  2. each window is thresholded at its own mean into a binary structure,
///     S_l(i, j) = 1 when L(i, j) > m_l, else 0 (S_r alike);
///  3. for every window element where S_l(i, j) = S_r(i, j), SV += W(i, j), with W the
///     weighting matrix (Fig. 3: equally weighted, or weights decreasing away from the centre);
///  4. the support value selects the matching candidates;
///  5. among them, cross-correlation (here zero-mean normalised, NCC) decides the match.
/// Then (§2.2-2.4): the epipolar and disparity-range constraints (rows of a rectified pair,
/// [min_disparity_px, max_disparity_px]); the uniqueness and ordering constraints (along a row
/// the accepted matches keep their order in both views and use a right pixel once; a conflict
/// is resolved for the higher correlation); the left-right consistency check (matching from
/// right to left with the same criterion, relaxed to lr_tolerance_px); the continuity
/// constraint (an isolated estimate, without enough neighbours at about its disparity, is
/// removed); the disparities of the holes this leaves (occlusions, mostly) are interpolated
/// from their neighbours along the row, and the map is smoothed with a median.
///
/// Beyond the paper (each an option; docs/matchers/support_value.md measures them): a few
/// pixels of the nearer side of every remaining depth jump are voided (edge_erosion_px: the
/// 13 x 13 window's foreground fattening survives the left-right check), holes take the
/// farther neighbour instead of a line between the two (fill), only holes up to max_fill_px are
/// filled, and optional shiftable windows (shift_px). With the defaults Tsukuba reaches bad1
/// 4.56 % over its non-occluded pixels at 90.9 % density (the paper's pipeline: 11.5 % at
/// 100 %). Disparities are whole pixels except where linear filling interpolates.
///
/// Windows are square, window_px x window_px (the paper's 13 x 13); pixels beyond the image
/// edge repeat the edge pixel, so every pixel has a window. Only disparities with u - d >= 0
/// are searched. The right view's matches come from the same support values and correlations
/// (a right pixel u_r at disparity d meets the left pixel u_r + d), so the right-to-left pass
/// costs no second cost computation.
///
/// Speed: each pixel's binary structure is packed once per image into ceil(window_px^2 / 64)
/// 64-bit words, so a support value is an XOR and a population count per word; with a
/// non-uniform weighting the weights are split into bit planes (one mask per bit of the
/// weight) and SV = sum_b 2^b * (agreements under plane b). The correlation's cross sums slide
/// over rows and columns (four integer operations per pixel and disparity). With Simd::kAvx2
/// the hot loops run from a copy compiled for AVX2 + POPCNT (chosen at run time); results are
/// identical bit for bit.
///
/// Disparity maps are ImageF32 in the left view [px], d = u_left - u_right >= 0;
/// kNoDisparity (dense_sad.h) where there is no estimate.

#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <string>
#include <vector>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"
#include "frontend/dense_sad.h"
#include "frontend/simd.h"

namespace twocam::frontend {

/// The weighting matrix W of the support value (the paper's Fig. 3).
enum class SupportWeighting {
  /// Every window element weighs 1 (Fig. 3a; the paper's experiments): SV counts agreements.
  kEqual,
  /// Decreasing order (Fig. 3b): rings of equal Chebyshev distance k from the centre weigh
  /// h + 1 - k, h = window_px / 2 (13 x 13: centre 7, outermost ring 1). The figure's numbers
  /// did not survive the paper's scan; this is the simplest matrix of that description.
  kDecreasing,
};

/// How the holes left by the checks are filled (the paper's "interpolation", §2.4, §2.5.1).
enum class SupportFill {
  kNone,     ///< Leave them without estimate (the validated matches only).
  kLinear,   ///< Linear interpolation along the row between the nearest estimates either side
             ///< (the paper); at a row's ends, the nearest estimate.
  kFarther,  ///< The smaller (farther) of the two neighbouring estimates: an occluded pixel
             ///< belongs to the background, which a straight line between the two surfaces
             ///< does not respect.
};

/// "none", "linear" or "farther".
const char* toString(SupportFill fill);
/// Parses toString()'s spellings; an error naming the accepted ones otherwise.
Status parseSupportFill(const std::string& text, SupportFill* fill);

struct SupportValueOptions {
  /// Side of the square support window [px], odd, in [3, 31]. 13 is the paper's (§4.1).
  int window_px = 13;
  /// Weighting matrix. kEqual, the paper's experimental setting ("support value equally
  /// weighted weighting matrix", §4.1).
  SupportWeighting weighting = SupportWeighting::kEqual;
  /// Custom weighting matrix, row-major window_px^2 integer weights in [0, 255]; when not
  /// empty it replaces `weighting`. Empty by default.
  std::vector<int> weights;
  /// Smallest disparity searched [px], >= 0.
  int min_disparity_px = 0;
  /// Largest disparity searched [px], inclusive; below the image width and at most
  /// min_disparity_px + 255. 63: the 64 disparities of the project's other matchers.
  int max_disparity_px = 63;
  /// Candidate selection: a disparity is a candidate when its support value is a local maximum
  /// over d and at least (1 - candidate_margin) x the best support value of the pixel, in
  /// [0, 1]. 0.05: the paper gives no number; Tsukuba non-occluded bad1 4.56 % (0.05),
  /// 4.86 % (0.1), 4.97 % (0.2) with the other defaults: wider margins let correlation pick
  /// look-alikes (docs/matchers/support_value.md).
  double candidate_margin = 0.05;
  /// Largest number of candidates handed to the correlation, best support values first, in
  /// [1, 16]. 3: a pixel seldom has more than two plausible rivals inside the margin. 1 (the
  /// support value alone decides) gives Tsukuba 4.43 % at 88.2 % density against 4.56 % at
  /// 90.9 %: correlation mostly adds density.
  int max_candidates = 3;
  /// Shiftable windows [px], in [0, min(7, window_px / 2)]: each pixel's support value at d is the
  /// best of the windows that contain it with their centre up to shift_px away in either direction
  /// (a maximum filter of the centred support values over (2 shift_px + 1)^2 pixels), and the
  /// correlation is taken on the window that won. Not in the paper, which centres its windows;
  /// at a depth edge some of these windows lie on one surface only, which takes back most of the
  /// foreground fattening of 13 x 13 windows (docs/matchers/support_value.md). 0 = the paper's
  /// centred windows.
  int shift_px = 0;
  /// A match is accepted only when its correlation (zero-mean NCC, in [-1, 1]) reaches this,
  /// in [-1, 1]. 0.5 as Bradley et al. (seed 003) use for NCC (Tsukuba: 0 gives 4.60 % at
  /// 91.2 %, 0.8 gives 3.65 % at 85.8 %); textureless windows (zero variance) never match.
  double min_correlation = 0.5;
  /// Enforce the uniqueness and ordering constraints along each row (both directions).
  bool ordering = true;
  /// Largest |d_left - d_right| the left-right check accepts [px], in [0, 4]; negative turns
  /// the check off. 1: the paper relaxes the bidirectional validation (§2.3: "2 to 4" px for
  /// inclined surfaces). Tsukuba 0 / 1 / 2 px: 4.14 / 4.56 / 4.64 % at 89.9 / 90.9 / 91.4 %
  /// density; Venus alike within 0.06 point.
  int lr_tolerance_px = 1;
  /// Continuity constraint: side of the square neighbourhood looked at [px], odd, in [3, 15];
  /// an estimate is kept when at least continuity_min_neighbours of the other estimates in it
  /// lie within 1 px of its disparity. 5: the scale of an isolated speck the check lets through.
  int continuity_window_px = 5;
  /// See continuity_window_px; in [0, continuity_window_px^2 - 1]; 0 turns the constraint off.
  /// 6 of 24: a quarter of the neighbourhood (off: Tsukuba 4.99 % at 92.2 %).
  int continuity_min_neighbours = 6;
  /// Depth-edge erosion [px], in [0, 15]; 0 turns it off. Not in the paper: wherever two
  /// validated estimates at most 3 px apart along a row or a column differ by more than 1 px,
  /// this many pixels of the nearer side, from the jump on, are voided and left to the filling,
  /// which takes the farther side: the centred window's foreground fattening (the nearer
  /// surface's texture dominates windows that straddle the edge) reaches up to half a window
  /// into the farther surface. 4, about a third of the 13 x 13 window: with the other defaults,
  /// Tsukuba non-occluded bad1 / density for 0, 2, 4, 6 px: 5.83 / 93.9, 4.98 / 92.2,
  /// 4.56 / 90.9, 4.27 / 89.8 % (docs/matchers/support_value.md).
  int edge_erosion_px = 4;
  /// How holes are filled after the checks. kFarther, a deviation from the paper's kLinear:
  /// with the other defaults Tsukuba non-occluded bad1 4.56 % against 6.48 % (linear), Venus
  /// 2.06 % against 3.55 %, at the same density.
  SupportFill fill = SupportFill::kFarther;
  /// Widest hole that is filled along a row [px], >= 0; 0 fills every hole (full density).
  /// Wider holes stay without estimate: they are where the checks found no trustworthy match
  /// over a stretch (large occlusions, textureless areas), and filling them is a guess. 12:
  /// with the other defaults Tsukuba keeps 90.9 % of its non-occluded pixels at bad1 4.56 %
  /// (8: 88.0 % at 3.87 %; 16: 93.6 % at 5.25 %; every hole: 100 % at 6.36 %).
  int max_fill_px = 12;
  /// Side of the median filter applied to the (filled) map [px], odd, in [1, 15]; 1 turns it
  /// off. The paper smooths after isolated-pixel removal without saying how. 11: Tsukuba
  /// non-occluded bad1 4.94 % (off), 4.73 % (5), 4.56 % (11), 4.65 % (15).
  int median_px = 11;
  /// Salient matcher only (matchSupportValueSalient): largest number of hypotheses kept per
  /// point, in [1, 255]. 4, the landmark database's budget (salient_sad.h).
  int max_hypotheses = 4;
  /// Salient matcher only: hypotheses are the local maxima of the support value within this
  /// margin of the best (fraction of the best, in [candidate_margin, 1]), wider than the dense
  /// candidate_margin so that the rival surfaces of a depth edge and repeated-texture aliases
  /// stay in the list. 0.15.
  double hypothesis_margin = 0.15;
  /// Which build of the hot loops runs (frontend/simd.h): kAvx2 (kAuto on an AVX2 CPU) the
  /// AVX2 + POPCNT copy, any other the baseline copy. Same results bit for bit.
  Simd simd = Simd::kAuto;

  /// Names the first broken constraint, e.g. "window_px = 12; must be odd".
  [[nodiscard]] Status validate() const;
};

/// Counts of one dense computation, as fractions of the paper's Fig. 13 can be read from
/// them (pixels of the left image).
struct SupportValueStats {
  int64_t pixels = 0;
  /// Left pixels with a match (a candidate whose correlation reached min_correlation).
  int64_t matched = 0;
  /// Of those, kept by the uniqueness and ordering constraints.
  int64_t ordered = 0;
  /// Of those, whose right-view match agrees exactly (the paper's "consistent without
  /// relaxation").
  int64_t lr_exact = 0;
  /// Of those kept by the constraints, whose right-view match agrees within lr_tolerance_px.
  int64_t lr_relaxed = 0;
  /// Estimates left after the continuity constraint and the depth-edge erosion (the
  /// validated map, before filling).
  int64_t validated = 0;
  /// Estimates after filling.
  int64_t filled = 0;
};

namespace internal {
/// A pixel's window sum [grey levels] and 1 / sqrt(n sum L^2 - (sum L)^2) (0: no variance);
/// SupportValueMatcher's scratch.
struct SupportWindowStats {
  int32_t sum = 0;
  float inv_std = 0.0f;
};
}  // namespace internal

/// Dense support-value matcher that keeps its scratch buffers between calls (one per thread;
/// not thread-safe). Results are a pure function of the inputs: reuse changes only the speed.
class SupportValueMatcher {
 public:
  /// Computes the left-view disparity map of a rectified pair (see the file comment).
  /// Fails (leaving *disparity untouched) when `disparity` is null, the images are empty or
  /// differ in size, max_disparity_px >= width, or the options are invalid.
  Status compute(const ImageU8& left,
                 const ImageU8& right,
                 const SupportValueOptions& options,
                 ImageF32* disparity);

  /// Right-view matches of the last successful compute() [px] after its ordering constraint
  /// (kNoDisparity where none), as the left-right check used them.
  [[nodiscard]] const ImageF32& rightDisparity() const { return right_disparity_; }
  /// The left map of the last successful compute() after the checks, before filling and
  /// smoothing (the validated matches).
  [[nodiscard]] const ImageF32& validatedDisparity() const { return validated_; }
  /// Counts of the last successful compute().
  [[nodiscard]] const SupportValueStats& stats() const { return stats_; }

 private:
  std::vector<uint8_t> left_pad_;
  std::vector<uint8_t> right_pad_;
  std::vector<uint64_t> left_masks_;
  std::vector<uint64_t> right_masks_;
  std::vector<int64_t> left_integral_;
  std::vector<int64_t> left_integral_sq_;
  std::vector<int64_t> right_integral_;
  std::vector<int64_t> right_integral_sq_;
  std::vector<int32_t> support_;
  std::vector<internal::SupportWindowStats> left_stats_;
  std::vector<internal::SupportWindowStats> right_stats_;
  std::vector<int32_t> best_support_;
  std::vector<uint8_t> best_offset_;
  std::vector<int32_t> column_support_;
  std::vector<uint8_t> column_offset_;
  std::vector<int32_t> col_cross_;
  std::vector<int32_t> cross_;
  std::vector<int16_t> left_d_;
  std::vector<float> left_score_;
  std::vector<int16_t> right_d_;
  std::vector<float> right_score_;
  ImageF32 right_disparity_;
  ImageF32 validated_;
  SupportValueStats stats_;
};

/// One-shot convenience wrapper around SupportValueMatcher::compute().
Status computeSupportValueDisparity(const ImageU8& left,
                                    const ImageU8& right,
                                    const SupportValueOptions& options,
                                    ImageF32* disparity);

/// Support-value hypotheses at salient points (same contract as matchSalient, salient_sad.h).
///
/// Fills out->points with one SalientPoint per input corner inside the left image
/// (0 <= u < width, 0 <= v < height; windows beyond the edge repeat the edge pixel), in input
/// order; other corners are skipped. A point's hypotheses are the local maxima of its support
/// value curve over [min_disparity_px, min(max_disparity_px, u)] within hypothesis_margin of
/// the best whose correlation reaches min_correlation, at most max_hypotheses, ranked by
/// correlation (rank 0 = the highest: the paper's decision). Per hypothesis: d_px the integer
/// disparity, cost = 1 - NCC (dimensionless, in [0, 2]; lower is better), lr_consistent when
/// matching the right window back along the left row with the same criterion lands within
/// lr_tolerance_px of it (a negative tolerance leaves every flag false), row_offset_px 0,
/// window_shift_px 0. SalientPoint::complete when no local maximum within the margin was
/// dropped for want of room and the search was not cut short by the left image edge.
/// out is cleared first and its capacity reused; out->t_ns is untouched.
/// Errors (out untouched): null out, empty or differently sized images, invalid options,
/// max_disparity_px >= width.
Status matchSupportValueSalient(const ImageU8& left,
                                const ImageU8& right,
                                const std::vector<Corner>& corners,
                                const SupportValueOptions& options,
                                StereoHypotheses* out);

}  // namespace twocam::frontend
