#pragma once
/// Pictures of a stereo evaluation that a person can read at a glance (BGR, 8-bit, ready for
/// cv::imwrite as PNG). Colours follow the definitions of stereo_metrics.h: a pixel or point
/// is judged only where it is evaluated (valid ground truth, outside options.border_px; masks
/// are not drawn). Disparities are colour-mapped with OpenCV's TURBO map over
/// [0, max_disp_px] (blue = far/small, red = near/large), black = no value.

#include <opencv2/core/mat.hpp>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"
#include "eval/disparity_io.h"
#include "eval/stereo_metrics.h"

namespace twocam::eval {

/// One row of four labelled panels, each the size of `left`:
///   left image | estimated disparity | ground-truth disparity | error map.
/// Error map: green |d - d_gt| <= bad1_px, orange <= bad2_px, red above, grey = evaluated but no
/// estimate, black = not evaluated (no ground truth, border, or outside `mask` when given: only
/// pixels whose mask value is 255 count, in the colours and in the caption's figures alike).
/// Errors: empty inputs; left, disparity and gt sizes differ; max_disp_px not finite and > 0;
/// options invalid.
Status renderDenseEvalPicture(const ImageU8& left,
                              const ImageF32& disparity,
                              const DisparityGroundTruth& gt,
                              double max_disp_px,
                              const StereoEvalOptions& options,
                              cv::Mat* picture,
                              const ImageU8* mask = nullptr);

/// Outcome of one salient point, as the salient picture colours it.
enum class SalientOutcome {
  kBestCorrect,     ///< rank-0 hypothesis within recall_tol_px (green)
  kCorrectWithinK,  ///< not the best, but a hypothesis with rank < k is (yellow)
  kWrong,           ///< hypotheses exist, none of the first k within tolerance (red)
  kNoHypothesis,    ///< the matcher gave no hypothesis (grey)
  kNotEvaluated,    ///< no ground truth there, or inside the border (blue)
};

/// Classifies point `index` of `hyps` (no bounds checks beyond TWOCAM_CHECK: the caller has
/// validated hyps, e.g. through evaluateSalient or renderSalientEvalPicture).
SalientOutcome classifySalientPoint(const StereoHypotheses& hyps,
                                    size_t index,
                                    const DisparityGroundTruth& gt,
                                    const StereoEvalOptions& options);

/// One row of three labelled panels, each the size of `left`:
///   left image with every salient point drawn as a small circle coloured by SalientOutcome,
///   filled when its best hypothesis is lr_consistent (an estimate), hollow when it is not,
///   with a count per outcome | the best hypothesis' disparity colour-mapped at each point on
///   the darkened left image | the ground-truth disparity.
/// Errors: as evaluateSalient (invalid hypotheses, points outside the image), plus empty left,
/// left size != gt size, max_disp_px not finite and > 0.
Status renderSalientEvalPicture(const ImageU8& left,
                                const StereoHypotheses& hyps,
                                const DisparityGroundTruth& gt,
                                double max_disp_px,
                                const StereoEvalOptions& options,
                                cv::Mat* picture,
                                const ImageU8* mask = nullptr);

}  // namespace twocam::eval
