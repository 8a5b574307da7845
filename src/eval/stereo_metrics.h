#pragma once
/// Stereo-pair metrics against ground-truth disparity, exactly as docs/conventions.md
/// ("Stereo pairs", `stereo-eval`) defines them, for dense disparity maps and for the salient
/// frontend's hypotheses.
///
/// Evaluated items: pixels (dense) or salient points (salient) with valid ground truth, inside
/// the mask when one is given (mask value 255 = keep), and at least border_px from every image
/// edge. Of those, an item "has an estimate" when
///   dense:   its disparity is finite and >= 0 (value < 0 = no estimate, the map convention);
///   salient: its best hypothesis (rank 0) passes the consistency checks ("single-best after
///            consistency checks"): its d_px is finite, it is lr_consistent, and no other
///            lr_consistent hypothesis of the point differs from it by more than
///            recall_tol_px (an unambiguous answer; the rule of frontend confidentBest()).
/// Then (all percentages are PERCENT, 0..100, as METRICS.md reports them):
///   bad1 / bad2 = 100 * #{estimated, |d - d_gt| > bad1_px / bad2_px} / #evaluated
///   bad0.5      = the same with bad05_px (0.5 px): sub-pixel accuracy
///   avgerr      = mean |d - d_gt| over estimated items [px]
///   density     = 100 * #estimated / #evaluated
/// Note the denominator of bad1/bad2 is every evaluated item, so a sparse method is not
/// punished for missing estimates there: read bad1 together with density.
/// A ratio with a zero denominator is NaN (written as JSON null).

#include <cstdint>
#include <limits>
#include <string>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"
#include "eval/disparity_io.h"
#include "io/json.h"

namespace twocam::eval {

struct StereoEvalOptions {
  /// Width of the frame along every image edge that is not evaluated [px]. 0 because the
  /// ground truth marks its own undefined border (Tsukuba's 18 px are 0 = unknown in disp3.pgm);
  /// set it to the matcher's half window to compare methods only where all can answer.
  int border_px = 0;
  /// Error above which an estimate counts in bad1 [px]; 1 as METRICS.md defines bad1.
  double bad1_px = 1.0;
  /// Error above which an estimate counts in bad2 [px]; 2 as METRICS.md defines bad2.
  double bad2_px = 2.0;
  /// Error above which an estimate counts in bad0.5 [px]; 0.5 as METRICS.md defines bad0.5.
  double bad05_px = 0.5;
  /// Number of best-ranked hypotheses recall_at_k looks at (salient mode). 4: the salient
  /// matcher keeps a handful of rivals per point; on the repetitive world the true one is
  /// often not the best but among the first few.
  int k = 4;
  /// A hypothesis is true when |d - d_gt| <= recall_tol_px [px]; 1 as METRICS.md defines a
  /// true stereo hypothesis.
  double recall_tol_px = 1.0;

  /// Errors name the broken constraint, e.g. "k = 0; must be >= 1".
  [[nodiscard]] Status validate() const;
};

/// Results of one evaluation. Percentages are PERCENT (0..100); NaN when undefined.
struct StereoMetrics {
  /// Percent of evaluated items with an estimate off by more than bad1_px / bad2_px.
  double bad1 = 0.0;
  double bad2 = 0.0;
  /// Percent of evaluated items with an estimate off by more than bad05_px (JSON key "bad0.5").
  double bad05 = 0.0;
  /// Mean absolute disparity error over evaluated items with an estimate [px].
  double avgerr = 0.0;
  /// Percent of evaluated items with an estimate.
  double density = 0.0;
  /// Salient: percent of evaluated points for which one of the hypotheses ranked < k (any
  /// consistency) is within recall_tol_px of the ground truth. Dense: one estimate per pixel,
  /// so k = 1 and this is the percent of evaluated pixels with an estimate within
  /// recall_tol_px (= density - bad1 when bad1_px = recall_tol_px).
  double recall_at_k = 0.0;
  /// Salient: the same with the best hypothesis only (regardless of consistency). Dense: equal
  /// to recall_at_k.
  double recall_at_1 = 0.0;
  /// The k used for recall_at_k (options.k in salient mode, 1 in dense mode).
  int k = 0;
  /// Mean number of hypotheses per evaluated point, all ranks and consistencies (salient).
  /// Dense: a pixel carries one estimate or none, so this is estimated / evaluated.
  double mean_hypotheses = 0.0;
  /// Salient: percent of evaluated points whose hypotheses all lie within recall_tol_px of the
  /// best one, so that they give one answer (the landmark database seeds such a point as a lone
  /// candidate, without rivals). Dense: NaN.
  double one_answer_fraction = std::numeric_limits<double>::quiet_NaN();
  /// Salient: percent of those one-answer points whose best hypothesis is within recall_tol_px
  /// of the ground truth: how often a lone candidate is real (docs/landmarks.md, prior_real_lone).
  /// Dense: NaN.
  double one_answer_precision = std::numeric_limits<double>::quiet_NaN();
  /// Items offered: pixels of the map (dense) or salient points detected (salient).
  int64_t points = 0;
  /// Items evaluated: valid ground truth, inside mask and border (denominator of percentages).
  int64_t evaluated = 0;
  /// Evaluated items with an estimate (denominator of avgerr).
  int64_t estimated = 0;
  /// Time the method took for this image [ms] and the same per megapixel [s/MP]; filled by the
  /// caller (setTiming), 0 until then. The evaluators do not time anything.
  double ms = 0.0;
  double s_per_mp = 0.0;
};

/// Evaluates a dense left-view disparity map (value < 0 or NaN = no estimate).
/// Errors: options invalid; gt empty or d_px/valid sizes differ; disparity size != gt size;
/// mask given and its size != gt size.
Status evaluateDense(const ImageF32& disparity,
                     const DisparityGroundTruth& gt,
                     const ImageU8* mask,
                     const StereoEvalOptions& options,
                     StereoMetrics* metrics);

/// Evaluates the salient frontend's output (see the file comment for the definitions).
/// The rank-0 hypothesis is found by its `rank` field; recall_at_k looks at hypotheses with
/// rank < k. Points with no hypotheses are evaluated (when they have ground truth) and count as
/// no estimate and not recalled. Errors: options or gt invalid; mask size != gt size; a point
/// outside the ground-truth image; a point's hypothesis range outside `hyps.hypotheses`, or a
/// hypothesis in it whose point_index is not that point's index.
Status evaluateSalient(const StereoHypotheses& hyps,
                       const DisparityGroundTruth& gt,
                       const ImageU8* mask,
                       const StereoEvalOptions& options,
                       StereoMetrics* metrics);

/// Salient-mode counts that add up over frames: a run's frontend figures are the metrics of
/// the summed counts (every evaluated point weighs the same), not a mean of per-frame
/// percentages. evaluateSalient() is tallySalient() on an empty tally, then metrics().
struct SalientTally {
  int k = 0;               ///< options.k of the tallies (all must share it)
  int64_t points = 0;      ///< salient points offered
  int64_t evaluated = 0;   ///< points evaluated (denominator of the percentages)
  int64_t estimated = 0;   ///< evaluated points with a single-best estimate
  int64_t bad1 = 0;        ///< estimated points off by more than bad1_px
  int64_t bad2 = 0;        ///< estimated points off by more than bad2_px
  int64_t bad05 = 0;       ///< estimated points off by more than bad05_px
  int64_t recalled_k = 0;  ///< evaluated points with a true hypothesis among rank < k
  int64_t recalled_1 = 0;  ///< evaluated points whose best hypothesis is true
  int64_t hypotheses = 0;  ///< hypotheses of the evaluated points
  int64_t one_answer =
      0;  ///< evaluated points whose hypotheses all lie within recall_tol_px of the best
  int64_t one_answer_true = 0;  ///< of those, points whose best hypothesis is true
  double abs_err_sum = 0.0;     ///< sum of |d - d_gt| over estimated points [px]

  /// The metrics of these counts (ms and s_per_mp left 0).
  [[nodiscard]] StereoMetrics metrics() const;
};

/// Adds one frame's salient output to `tally` (same checks and errors as evaluateSalient; on
/// error the tally is unchanged).
Status tallySalient(const StereoHypotheses& hyps,
                    const DisparityGroundTruth& gt,
                    const ImageU8* mask,
                    const StereoEvalOptions& options,
                    SalientTally* tally);

/// Fills ms and s_per_mp = (ms / 1000) / (width * height / 1e6). Non-positive sizes give
/// s_per_mp = NaN.
void setTiming(double ms, int width_px, int height_px, StereoMetrics* metrics);

/// The metrics as a JSON object (io/json.h) with METRICS.md's keys first, in this fixed order:
/// bad1, bad2, bad0.5, avgerr, density, recall_at_k, points, ms, s_per_mp, then k, recall_at_1,
/// mean_hypotheses, evaluated, estimated, one_answer_fraction, one_answer_precision; NaN and
/// infinities are null.
io::Json toJsonValue(const StereoMetrics& metrics);

/// Its text by TwoCam's JSON writer (io::toJsonText, 10 significant digits, one key per line);
/// no trailing newline.
std::string toJson(const StereoMetrics& metrics);

/// Writes toJson(metrics) plus a newline to `path`. Errors name the path.
Status writeJson(const std::string& path, const StereoMetrics& metrics);

}  // namespace twocam::eval
