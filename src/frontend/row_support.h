#pragma once
/// Row support of salient hypotheses: how well a hypothesis' window matches on the rows above and
/// below, stored as DisparityHypothesis::row_span_px (the landmark database does not seed
/// hypotheses whose rows disagree; SalientSadOptions::row_support).

#include "frontend/salient_sad.h"

namespace twocam::frontend {

/// Row support of every hypothesis in `hyps` (computed on `left`/`right`, the pair the
/// hypotheses came from): for the rows v - 1 and v + 1 that exist (right rows shifted by the
/// hypothesis' row_offset_px), the 1xW window of the hypothesis' alignment (window_shift_px)
/// is compared with the right image at integer disparities D - R - 1 .. D + R + 1 (D = the
/// rounded d_px, R = options.row_support_radius_px, clipped to the image); the cheapest of
/// D - R .. D + R, parabola-refined, is that row's disparity. row_span_px = max - min of d_px
/// and those row disparities (0 when neither row could be matched). A row whose best lies at
/// D +- R therefore adds about R px: it prefers a disparity outside the radius. With AVX2 (and
/// plain SAD, 4 <= W <= 16) the costs come from SSE4.1's mpsadbw; the result is the same bit for
/// bit. Errors (hyps untouched) as matchSalient's input checks, or for a point whose hypothesis
/// range runs past the hypotheses, whose corner lies outside the images, or one of whose
/// hypotheses has a d_px that is not in [0, 32768] (NaN included).
Status measureRowSupport(const ImageU8& left,
                         const ImageU8& right,
                         const SalientSadOptions& options,
                         StereoHypotheses* hyps);

}  // namespace twocam::frontend
