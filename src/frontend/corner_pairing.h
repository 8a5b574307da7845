#pragma once
/// Paper A §5.5.2 "spurious matching": every right corner inside the search window W_m(F_i) of a
/// left corner F_i (rows v +- m, disparities in range) is a hypothesis for F_i; the landmark
/// database, not the matcher, decides which one is real. Fills the same StereoHypotheses as
/// matchSalient() (salient_sad.h), so the two sources can be compared.

#include <vector>

#include "frontend/salient_sad.h"

namespace twocam::frontend {

/// Paper A's spurious matching: every right corner (ur, vr) with |vr - v| <= m and
/// d = u - ur in [min_disparity_px, max_disparity_px] is a hypothesis of left corner (u, v),
/// with d_px = d (integer: both corners are integer pixels), row_offset_px = vr - v and cost
/// the 1xW SAD (plain or zero-mean as options say) between the two corners' windows (with
/// shiftable_windows, the lowest over the three alignments that fit both images). The
/// max_hypotheses cheapest are kept, ranked by cost (ties: smaller disparity first); those
/// above max_cost_per_px * W are dropped. cost_ratio, min_separation_px and lr_tolerance_px
/// are not used: Paper A keeps every pair in the window.
///
/// lr_consistent (when options.lr_check) is the mutual-best test among corners: true when no
/// other left corner pairs with the same right corner at a lower cost (ties all count).
///
/// Points, skipping and errors as matchSalient (right corners whose window does not fit the
/// right image are ignored). Right corners are bucketed by row, so the work is
/// O(left corners x right corners per 2m+1 rows), not all pairs.
Status pairCorners(const ImageU8& left,
                   const ImageU8& right,
                   const std::vector<Corner>& left_corners,
                   const std::vector<Corner>& right_corners,
                   const SalientSadOptions& options,
                   StereoHypotheses* out);

}  // namespace twocam::frontend
