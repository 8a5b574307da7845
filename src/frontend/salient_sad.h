#pragma once
/// Stereo hypotheses at salient points of a rectified pair, two ways:
///
/// - matchSalient(): Paper B's 1-D SAD. For each left corner (u, v) the 1xW window
///   L(u-h..u+h, v), h = (W-1)/2, is compared with R(u-h-d..u+h-d, v+r) for every disparity
///   d in [min_disparity_px, max_disparity_px] and row offset r in [-m, m]; with
///   shiftable_windows (default) also the windows ending at and starting at u. The cost
///   curves' distinct local minima within cost_ratio of the best become the point's rival
///   hypotheses (up to max_hypotheses), each with a parabola-fitted sub-pixel disparity and a
///   right-to-left consistency flag. The SAD runs 16 (SSE2) or 32 (AVX2) disparities per
///   instruction: one left pixel against consecutive right pixels, summed in uint16 lanes.
/// - pairCorners() (corner_pairing.h): Paper A §5.5.2 "spurious matching". Every right corner
///   inside the search window W_m(F_i) (rows v +- m, disparities in range) is a hypothesis for
///   left corner F_i; the database, not the matcher, decides which one is real.
///
/// Both fill the same StereoHypotheses (common/features.h) so the two sources can be compared.
/// measureRowSupport() (row_support.h) adds each hypothesis' agreement with the rows above and
/// below. The cost-curve kernels and their choice (Simd) are in sad_kernels.h.
/// Disparity d = u_left - u_right >= 0 (docs/conventions.md).

#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <vector>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"
#include "frontend/sad_kernels.h"

namespace twocam::frontend {

struct SalientSadOptions {
  /// Width W of the 1xW matching window [px], odd, in [3, 63]. 11 is inside Paper B's
  /// 3..21 range and long enough for a unique match on textured rows.
  int window_width_px = 11;
  /// Smallest disparity searched [px], >= 0 (rectified rig: the right view is shifted left).
  int min_disparity_px = 0;
  /// Largest disparity searched [px]; max - min + 1 <= 256. 63 gives the 64 disparities of
  /// the papers' FPGA design.
  int max_disparity_px = 63;
  /// Row tolerance m [px], in [0, 8]: right rows v-m..v+m are searched too. Paper A's
  /// "calibration accuracy value"; 0 because our pairs are rectified in software.
  int row_tolerance_px = 0;
  /// Largest number K of rival hypotheses kept per point, in [1, 255]. 4 is the budget the
  /// landmark database is sized for (recall_at_k is reported for k <= 4).
  int max_hypotheses = 4;
  /// A local minimum is kept when its cost <= cost_ratio * best cost (>= 1). 3 keeps
  /// repeated-texture aliases and the rival surfaces of a depth edge while K bounds the list
  /// (measured on Tsukuba and Venus: 1.7-2.1 hypotheses per point, recall_at_4 higher than
  /// with 2); the landmark database, not the matcher, decides between rivals.
  float cost_ratio = 3.0f;
  /// SalientPoint::complete is set only when no local minimum costing at most
  /// complete_cost_ratio x the best cost (the best taken as at least 1 grey level per pixel)
  /// continues a period of the list (2 d_i - d_j, within 1 px) without being in it
  /// (>= cost_ratio). Twice cost_ratio: on a periodic texture with
  /// sharp edges the true disparity can sit half a pixel off the integer grid while an alias
  /// sits on it, and cost 3-5x as much (measured on the repetitive world's checkered end wall:
  /// 96 against 21 for the alias); the landmark database trusts a complete list to hold the
  /// real point.
  float complete_cost_ratio = 6.0f;
  /// Distinct minima are at least this far apart in disparity [px] (>= 1); the cheaper one
  /// of a closer pair wins. Minima of one curve are never adjacent, so 1 merges only the same
  /// disparity found by two curves (rows, window alignments) and keeps neighbours 1 px apart:
  /// the two sides of a 1 px disparity step, either of which the truth may be (measured on
  /// Tsukuba non-occluded: recall_at_4 +0.5..0.9 points over 2, fewer wrong confident bests).
  int min_separation_px = 1;
  /// Right-to-left check: the right window of a hypothesis is matched back along the left row
  /// (same disparity range, row of the corner); the hypothesis is lr_consistent when that
  /// search's lowest cost is reached within this many px of the hypothesis' integer disparity
  /// (>= 0; ties count, so equal-cost aliases of a periodic texture all pass). 1 px tolerates
  /// the half-pixel rounding of two integer searches.
  int lr_tolerance_px = 1;
  /// Run the right-to-left check. false leaves every lr_consistent flag false (saves one
  /// cost curve per hypothesis).
  bool lr_check = true;
  /// Hypotheses whose cost exceeds max_cost_per_px * W are dropped [grey levels per pixel],
  /// > 0. 255 (the largest possible absolute difference) disables the gate; the landmark
  /// database sorts out weak matches over time, so the default drops nothing.
  float max_cost_per_px = 255.0f;
  /// Shiftable windows: besides the centred window, also match the windows that end at the
  /// corner (u-W+1..u) and start at it (u..u+W-1); their minima join the candidates. At a
  /// depth edge one of them lies on the corner's own surface, which recovers disparities a
  /// centred window misses (foreground fattening). On by default: Harris corners sit on depth
  /// edges more often than not, and for plain SAD the three windows share one pass over 2W-1
  /// columns (measured 1.3-1.5x the centred window's time). A hypothesis' cost and
  /// right-to-left check use the window alignment that produced it.
  bool shiftable_windows = true;
  /// Zero-mean SAD: each window's mean (rounded to an integer) is subtracted before the
  /// absolute differences, so a brightness offset between the cameras costs nothing (a gain
  /// difference only partly). false by default: plain SAD is the papers' cost and about 2-3x
  /// cheaper; turn it on when the cameras' exposure differs (measured on Tsukuba with the
  /// right view at 0.85 x + 30: best-hypothesis recall 90.8 % against 76.5 % for plain SAD).
  bool zero_mean = false;
  /// Sampling-insensitive cost (Birchfield and Tomasi 1998, one-sided): each left pixel is
  /// compared with the interval its right pixel spans up to half a pixel either side (linear
  /// interpolation), max(0, lo - l, l - hi) instead of |l - r|, so a real disparity half a
  /// pixel off the integer grid costs about as little as one on it. The right-to-left check
  /// uses it too (left intervals); row support and pairCorners() stay plain SAD. With
  /// zero_mean the window means come from the pixels and the mean-shifted left pixel is
  /// compared with the interval. false here (the papers' cost, and the matcher's stereo-eval
  /// figures); `twocam run` turns it on (docs/frontend.md, "Sampling-insensitive cost").
  bool birchfield_tomasi = false;
  /// Which SAD kernels run (frontend/simd.h; results are identical). Frontend sets it from
  /// FrontendOptions::simd, the config's one SIMD knob (frontend.simd).
  Simd simd = Simd::kAuto;
  /// Row support (measureRowSupport): after matching, the frontend matches each hypothesis'
  /// window on the rows above and below within +-row_support_radius_px of its disparity and
  /// stores the spread in DisparityHypothesis::row_span_px. Off for the matcher alone (its
  /// stereo-eval figures were measured without it); `twocam run` turns it on, because the
  /// landmark database does not seed hypotheses whose rows disagree (docs/landmarks.md).
  bool row_support = false;
  /// Search radius of the row-support match around the hypothesis' integer disparity [px], in
  /// [1, 16]. 3 covers the disparity change of a slanted floor between rows (B/h px per row, 0.24
  /// on the simulated rigs) and sub-pixel noise, while staying far below the spacing of
  /// periodic-texture aliases, which the other rows would otherwise match instead.
  int row_support_radius_px = 3;

  /// OK, or an error naming the first broken constraint and its value.
  [[nodiscard]] Status validate() const;
};

/// Paper B's salient 1-D SAD matcher (see the file comment).
///
/// Fills out->points with one SalientPoint per input corner whose window fits the left image
/// (h <= u < width - h, 0 <= v < height), in input order; other corners are skipped. Each
/// point's hypotheses sit in out->hypotheses[first_hypothesis, first_hypothesis + num):
/// ranked by cost (rank 0 = cheapest), point_index linking rivals. A point may have none
/// (all minima gated by max_cost_per_px).
///
/// Per hypothesis: d_px is the integer minimum refined by a parabola through the costs at
/// d-1, d, d+1 of the same curve, i.e. row and window alignment (|offset| <= 0.5; integer at
/// the ends of the searched range); cost is that window's SAD (or interval cost, birchfield_tomasi)
/// [grey levels] at the integer minimum; row_offset_px is r. Equal costs prefer small |r| (then r <
/// 0), then the centred window, then small d.
///
/// Disparities whose right window would leave the image are not searched, nor are right rows
/// outside the image. out is cleared first and its capacity reused; out->t_ns is untouched.
/// Errors (out untouched): null out, empty or differently sized images, invalid options, or
/// max_disparity_px + window_width_px > image width.
Status matchSalient(const ImageU8& left,
                    const ImageU8& right,
                    const std::vector<Corner>& corners,
                    const SalientSadOptions& options,
                    StereoHypotheses* out);

/// The point's rank-0 hypothesis when it passed the right-to-left check and no rival that
/// disagrees with it by more than agree_px [px] did; nullptr otherwise (no hypotheses, best
/// inconsistent, or ambiguous: consistent rivals at another depth). Rivals within agree_px
/// (default 1 px, the truth tolerance of METRICS.md) are the same answer, e.g. the two sides
/// of a 1 px disparity step. This is the "single best passes the consistency checks" of the
/// bad1 figures. `point` must belong to `hyps`.
[[nodiscard]] const DisparityHypothesis* confidentBest(const StereoHypotheses& hyps,
                                                       const SalientPoint& point,
                                                       float agree_px = 1.0f);

}  // namespace twocam::frontend
