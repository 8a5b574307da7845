#pragma once
/// Value structs the frontend hands to the landmark database: salient points of the left
/// image and, per point, one or more disparity hypotheses. Flat arrays (no vector per point)
/// so a frame's hypotheses cost two allocations, reused from frame to frame.

#include <cstdint>
#include <vector>

namespace twocam {

/// A Harris corner at an integer pixel of the left image.
struct Corner {
  int u_px = 0;
  int v_px = 0;
  /// Harris response det(M) - k trace(M)^2 in the detector's fixed scale (see frontend/harris.h).
  float response = 0.0f;
};

/// One disparity hypothesis for a salient point: u_right = u_left - d_px on the same row
/// (plus row_offset_px when the matcher searches +-m rows for calibration tolerance).
struct DisparityHypothesis {
  /// Sub-pixel disparity [px] (parabola fit around the integer minimum).
  float d_px = 0.0f;
  /// Matching cost at the integer minimum, summed over the window [grey levels]: SAD, or the
  /// Birchfield-Tomasi interval cost when the matcher used it (SalientSadOptions).
  float cost = 0.0f;
  /// Index of the salient point this hypothesis belongs to (StereoHypotheses::points).
  uint32_t point_index = 0;
  /// Row offset of the right match [px]; 0 unless row tolerance is enabled.
  int8_t row_offset_px = 0;
  /// Rank among the point's hypotheses by cost, 0 = best.
  uint8_t rank = 0;
  /// True when matching the right window back along the left row lands on this
  /// hypothesis again (within the matcher's tolerance).
  bool lr_consistent = false;
  /// Column shift of the matching window relative to the corner [px]: 0 for the centred
  /// window, -h / +h when a window ending / starting at the corner matched (shiftable windows,
  /// the sign of a depth edge through the corner).
  int8_t window_shift_px = 0;
  /// Row support [px]: spread max - min of this disparity and the best disparities of the same
  /// window on the rows above and below, searched within a few px of it (frontend
  /// measureRowSupport). A 1xW window is blind across rows; a real match on a surface whose
  /// depth is well defined at the corner is matched at about the same disparity one row up and
  /// down. 0 when not measured.
  float row_span_px = 0.0f;
};

/// A salient point and the range of its hypotheses in StereoHypotheses::hypotheses.
struct SalientPoint {
  Corner corner;
  uint32_t first_hypothesis = 0;
  uint32_t num_hypotheses = 0;
  /// True when the hypotheses are every candidate disparity the matcher found: no minimum within
  /// its cost ratio was dropped for want of room (max_hypotheses), the search was not cut short
  /// by the image border, and no dearer minimum continues a period of the list (see
  /// SalientSadOptions::complete_cost_ratio). If any disparity of this corner is real, it is then
  /// one of the hypotheses. False when unknown (the landmark database then assumes the worst).
  bool complete = false;
};

/// Everything the frontend says about one stereo frame. Rival hypotheses are those sharing
/// a point_index: at most one of them is real.
struct StereoHypotheses {
  int64_t t_ns = 0;
  std::vector<SalientPoint> points;
  std::vector<DisparityHypothesis> hypotheses;

  void clear() {
    points.clear();
    hypotheses.clear();
  }
};

}  // namespace twocam
