#pragma once
/// Scaled-window NCC stereo on a rectified 8-bit pair: the binocular part of Bradley,
/// Boubekeur and Heidrich, "Accurate multi-view reconstruction using robust binocular stereo
/// and surface meshing", CVPR 2008, §4 (docs/matchers/ncc_scaled.md).
///
/// Matching (§4, eq. 1): for a left (primary) pixel (u, v) the N x N window
/// L(u+i, v+j), i, j in [-h, h], N = 2h + 1, is compared by normalised cross-correlation with
/// the right (reference) samples R(u - d + s i, v + j) for every integer disparity d in
/// [min_disparity_px, max_disparity_px] and every horizontal window scale s in
/// {1/sqrt(2), 1, sqrt(2)} (the paper's scaled windows: a surface slanted about the vertical
/// axis looks horizontally stretched in one view, eq. 2). Right samples between pixels are
/// linearly interpolated. The match is the (d, s) of largest NCC; below ncc_threshold (0.5)
/// the pixel has no estimate. Only (d, s) whose right samples all lie inside the image
/// compete, so columns near the left edge search a shorter range.
///
/// Sub-pixel (§4 "Subpixel optimization"): at the winning scale, NCC is evaluated at the
/// 2n disparities d + k/n, k = +-1..+-n (n = subpixel_steps, 10: 1/10 px), the right view
/// linearly interpolated; the largest NCC wins (the integer one on ties).
///
/// Filtering (§4 "Filtering", Table 2): a median-rejection filter voids every estimate that
/// differs by more than median_rejection_px from the median of the estimates in a
/// median_size_px square around it; then an NCC-weighted bilateral filter ("trilateral")
/// replaces every estimate by the mean of the estimates in a bilateral_size_px square, each
/// weighted by exp(-r^2 / 2 sigma_s^2) exp(-(d_p - d_q)^2 / 2 sigma_r^2) NCC_q.
///
/// Disparity maps are ImageF32 in the left view [px], d = u_left - u_right >= 0,
/// kNoDisparity (< 0) = no estimate (frontend/dense_sad.h's convention). Values are multiples
/// of 1/subpixel_steps px before the bilateral filter, arbitrary floats after it.
///
/// Speed: the left and right window sums come from box sums computed once (per scale for the
/// right view); the correlation sums of one image row are computed once per (scale,
/// disparity) and kept in a ring of N rows, so each window costs N multiply-adds per scale
/// and disparity plus N adds; see tests/bench/ncc_scaled_bench.cpp.
///
/// Salient (matchNccSalient): the same NCC at given corners, every local maximum of the
/// best-over-scales NCC curve above the threshold and within hypothesis_margin of the best
/// becomes a hypothesis (sub-pixel as above), with a right-to-left check.

#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <vector>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"

namespace twocam::frontend {

/// Number of window scales searched (1/sqrt(2), 1, sqrt(2)).
constexpr int kNccScaleCount = 3;
/// The horizontal window scales of the paper, in index order (scale index 0, 1, 2).
constexpr float kNccScales[kNccScaleCount] = {0.70710678f, 1.0f, 1.41421356f};
/// Scale index meaning "no estimate" in NccScaledMatcher::scaleIndex().
constexpr uint8_t kNoScale = 255;

struct NccScaledOptions {
  /// Side N of the square matching window in the left view [px], odd, in [3, 31]. 5, the
  /// paper's Table 2 ("stereo window matching size 5 x 5").
  int window_size_px = 5;
  /// Smallest disparity searched [px], >= 0.
  int min_disparity_px = 0;
  /// Largest disparity searched [px], >= min_disparity_px, below the image width.
  int max_disparity_px = 63;
  /// Search the scaled windows 1/sqrt(2) and sqrt(2) besides the square one. false matches
  /// with the square window only (scale 1), the plain NCC the paper improves on.
  bool scaled_windows = true;
  /// Matches with NCC below this have no estimate, in [-1, 1]. 0.5, the paper's "NCC lower
  /// threshold" (Table 2): "we ignore very bad matches by thresholding the NCC to [0.5, 1]".
  float ncc_threshold = 0.5f;
  /// Windows whose grey-level standard deviation is below this are not matched [grey levels],
  /// >= 0: NCC is undefined on a flat window. 1 grey level: below, 8-bit quantisation and
  /// sensor noise decide the correlation (not in the paper).
  float min_window_std = 1.0f;
  /// n of the sub-pixel local search: 2n extra NCC evaluations between d - 1 and d + 1, a
  /// nominal precision of 1/n px, in [1, 64]; 0 turns the refinement off. 10, the paper's
  /// "1/10 pixels" (Table 2; "larger values have a diminishing return").
  int subpixel_steps = 10;
  /// Run the median-rejection filter (paper §4 "Filtering").
  bool median_rejection = true;
  /// Side of the median-rejection window [px], odd, >= 3. 15, the paper's Table 2.
  int median_size_px = 15;
  /// An estimate farther than this from its window's median is rejected [px], > 0. 2, the
  /// paper's Table 2 threshold (read as pixels of disparity).
  float median_rejection_px = 2.0f;
  /// Run the NCC-weighted bilateral ("trilateral") filter (paper §4 "Filtering").
  bool bilateral = true;
  /// Side of the bilateral window [px], odd, >= 3. 15, the paper's Table 2.
  int bilateral_size_px = 15;
  /// Spatial sigma of the bilateral filter [px], > 0. 4, the paper's Table 2 domain sigma.
  float bilateral_sigma_space_px = 4.0f;
  /// Range sigma of the bilateral filter [px of disparity], > 0. 1: the paper's Table 2 gives
  /// 10, which we read in its disparity unit of 1/10 px (its sub-pixel step); measured on Venus
  /// in docs/matchers/ncc_scaled.md.
  float bilateral_sigma_range_px = 1.0f;

  // Salient matching only.
  /// Largest number of hypotheses kept per salient point, in [1, 255]. 4, as SalientSadOptions.
  int max_hypotheses = 4;
  /// A local NCC maximum becomes a hypothesis when its NCC >= best - hypothesis_margin
  /// (and >= ncc_threshold), in [0, 2]. 0.3: on Venus and Tsukuba (non-occluded) it gives 1.6-1.7
  /// hypotheses per point, the regime of the SAD matcher the landmark database is tuned for
  /// (1.7-2.1), with recall_at_4 98.7 / 93.4 % against 98.3 / 92.8 % at 0.1 (1.1-1.2 per point);
  /// the best hypothesis is the same at any margin (docs/matchers/ncc_scaled.md).
  float hypothesis_margin = 0.3f;
  /// Right-to-left check tolerance [px], >= 0: a hypothesis is lr_consistent when the right
  /// window (square, at its integer match) searched back along the left row over every scale
  /// peaks within this distance of the hypothesis' integer disparity. 1 px.
  int lr_tolerance_px = 1;

  /// OK, or an error naming the first broken constraint and its value.
  [[nodiscard]] Status validate() const;
};

/// Dense scaled-window NCC matcher that keeps its scratch buffers between calls (one per
/// thread; not thread-safe). Results are a pure function of the inputs.
class NccScaledMatcher {
 public:
  /// Computes the left-view disparity map of a rectified pair (file comment), then the
  /// filters the options ask for. Fails (leaving the outputs untouched) when `disparity` is
  /// null, the images are empty or differ in size, max_disparity_px >= width, the window does
  /// not fit the image, or the options are invalid.
  Status compute(const ImageU8& left,
                 const ImageU8& right,
                 const NccScaledOptions& options,
                 ImageF32* disparity);

  /// NCC of each pixel's match in the last successful compute() (after the sub-pixel search),
  /// -1 where the window was not matched; defined also where the match fell below the
  /// threshold or was rejected by the median filter.
  [[nodiscard]] const ImageF32& ncc() const { return ncc_; }
  /// Index into kNccScales of each pixel's winning scale in the last successful compute(),
  /// kNoScale where the final map has no estimate.
  [[nodiscard]] const ImageU8& scaleIndex() const { return scale_index_; }

 private:
  std::vector<float> left_f_;
  std::vector<float> frac_images_;
  std::vector<float> left_sum_;
  std::vector<float> left_inv_;
  std::vector<float> right_sum_;
  std::vector<float> right_inv_;
  std::vector<float> ring_;
  std::vector<float> best_ncc_;
  std::vector<int32_t> best_code_;
  std::vector<float> work_;
  ImageF32 ncc_;
  ImageU8 scale_index_;
};

/// One-shot convenience wrapper around NccScaledMatcher::compute().
Status computeNccScaledDisparity(const ImageU8& left,
                                 const ImageU8& right,
                                 const NccScaledOptions& options,
                                 ImageF32* disparity);

/// NCC (eq. 1) of the left N x N window at integer (u, v) against the samples
/// R(x_right + s i, v + j), i, j in [-h, h], linearly interpolated: the quantity the matcher
/// maximises. Returns NaN when a sample leaves the image, when the left window leaves it, or
/// when either window's standard deviation is below min_std. Roles swap when `left` is the
/// right image (right-to-left check).
[[nodiscard]] float nccAt(const ImageU8& left,
                          const ImageU8& right,
                          int u,
                          int v,
                          double x_right,
                          float scale,
                          int window_size_px,
                          float min_std);

/// Median-rejection filter (paper §4): every estimate (>= 0) farther than threshold_px from
/// the median (the lower one for an even count) of the estimates in the size_px square
/// around it (clipped at the border) becomes kNoDisparity. The median is taken over the values
/// rounded to multiples of 1/steps px (a sliding histogram), so it is exact for maps on that
/// grid (the matcher's output before the bilateral filter). Fails when the map is null or empty,
/// size_px is even or < 1, steps is not in [1, 64], threshold_px <= 0, or a value exceeds
/// 4096 px.
Status medianRejectDisparity(int size_px, float threshold_px, int steps, ImageF32* disparity);

/// NCC-weighted bilateral filter (paper §4, "trilateral"): every estimate becomes
/// sum_q w_q d_q / sum_q w_q over the estimates q in the size_px square around it, with
/// w_q = exp(-|p-q|^2 / 2 sigma_space^2) exp(-(d_p - d_q)^2 / 2 sigma_range^2) max(ncc_q, 0).
/// Pixels without estimate stay without. Fails when sizes differ, size_px is even or < 1, or
/// a sigma is not > 0.
Status nccBilateralFilter(const ImageF32& ncc,
                          int size_px,
                          float sigma_space_px,
                          float sigma_range_px,
                          ImageF32* disparity);

/// Salient scaled-window NCC (file comment) with the contract of frontend::matchSalient():
/// one SalientPoint per corner whose window fits (h <= u < width - h, h <= v < height - h), in
/// input order; its hypotheses ranked by NCC (rank 0 = largest), cost = 1 - NCC
/// [dimensionless, 0..2], d_px sub-pixel, lr_consistent from the right-to-left check,
/// row_offset_px and window_shift_px 0. `complete` is set when every local maximum within the
/// margin was kept and the whole disparity range was searched. When `scale_index` is not
/// null it receives, parallel to out->hypotheses, each hypothesis' index into kNccScales.
/// out is cleared first; errors (out untouched): null out, empty or differently sized
/// images, invalid options, max_disparity_px >= width.
Status matchNccSalient(const ImageU8& left,
                       const ImageU8& right,
                       const std::vector<Corner>& corners,
                       const NccScaledOptions& options,
                       StereoHypotheses* out,
                       std::vector<uint8_t>* scale_index = nullptr);

}  // namespace twocam::frontend
