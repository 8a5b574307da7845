#include "frontend/salient_sad.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <string>

#include "frontend/cost_curve.h"

namespace twocam::frontend {
namespace {

using internal::checkInputs;
using internal::costCurve;
using internal::costGate;
using internal::CurveScratch;
using internal::forEachLocalMinimum;
using internal::kCurveStride;
using internal::kGuard;
using internal::kMaxDisparities;
using internal::kMaxDisparityPx;
using internal::kMaxHypothesesLimit;
using internal::kMaxPadded;
using internal::kMaxRowSupportRadius;
using internal::kMaxRowTolerance;
using internal::kMaxWindow;
using internal::kMinWindow;
using internal::minCost;
using internal::parabolaOffset;
using internal::setGuards;
using internal::stripFor;
using internal::StripSource;

/// One cost curve of a corner: right row v + row_offset_px, window columns
/// u + align_px - h .. u + align_px + h (align_px = 0 is the centred window).
struct Curve {
  int row_offset_px = 0;
  int align_px = 0;
  int d_hi = 0;  // curve index t <-> disparity d_hi - t
  int n = 0;
  uint16_t* cost = nullptr;
};

/// A local minimum of one curve.
struct Candidate {
  int cost;
  int d_px;
  int t;      // index in the curve
  int curve;  // index of the curve; curves are ordered by preference for equal costs
};

bool cheaper(const Candidate& a, const Candidate& b) {
  if (a.cost != b.cost) return a.cost < b.cost;
  if (a.curve != b.curve) return a.curve < b.curve;
  return a.d_px < b.d_px;
}

}  // namespace

Status SalientSadOptions::validate() const {
  auto fail = [](const std::string& what) { return Status::error(what); };
  if (window_width_px < kMinWindow || window_width_px > kMaxWindow || window_width_px % 2 == 0) {
    return fail("window_width_px = " + std::to_string(window_width_px) +
                "; must be odd and in [3, 63]");
  }
  if (min_disparity_px < 0 || min_disparity_px > kMaxDisparityPx) {
    return fail("min_disparity_px = " + std::to_string(min_disparity_px) + "; must be in [0, " +
                std::to_string(kMaxDisparityPx) + "]");
  }
  if (max_disparity_px < min_disparity_px || max_disparity_px > kMaxDisparityPx) {
    return fail("max_disparity_px = " + std::to_string(max_disparity_px) +
                "; must be in [min_disparity_px = " + std::to_string(min_disparity_px) + ", " +
                std::to_string(kMaxDisparityPx) + "]");
  }
  if (max_disparity_px - min_disparity_px + 1 > kMaxDisparities) {
    return fail("max_disparity_px - min_disparity_px + 1 = " +
                std::to_string(max_disparity_px - min_disparity_px + 1) + "; must be <= 256");
  }
  if (row_tolerance_px < 0 || row_tolerance_px > kMaxRowTolerance) {
    return fail("row_tolerance_px = " + std::to_string(row_tolerance_px) + "; must be in [0, 8]");
  }
  if (max_hypotheses < 1 || max_hypotheses > kMaxHypothesesLimit) {
    return fail("max_hypotheses = " + std::to_string(max_hypotheses) + "; must be in [1, 255]");
  }
  if (!std::isfinite(cost_ratio) || cost_ratio < 1.0f) {
    return fail("cost_ratio = " + std::to_string(cost_ratio) + "; must be finite and >= 1");
  }
  if (!std::isfinite(complete_cost_ratio) || complete_cost_ratio < cost_ratio) {
    return fail("complete_cost_ratio = " + std::to_string(complete_cost_ratio) +
                "; must be finite and >= cost_ratio");
  }
  // A separation or tolerance wider than the searched range (<= 256 disparities) acts as that
  // range; the bound keeps d +- tolerance inside int.
  if (min_separation_px < 1 || min_separation_px > kMaxDisparities) {
    return fail("min_separation_px = " + std::to_string(min_separation_px) + "; must be in [1, " +
                std::to_string(kMaxDisparities) + "]");
  }
  if (lr_tolerance_px < 0 || lr_tolerance_px > kMaxDisparities) {
    return fail("lr_tolerance_px = " + std::to_string(lr_tolerance_px) + "; must be in [0, " +
                std::to_string(kMaxDisparities) + "]");
  }
  if (!std::isfinite(max_cost_per_px) || max_cost_per_px <= 0.0f) {
    return fail("max_cost_per_px = " + std::to_string(max_cost_per_px) +
                "; must be finite and > 0");
  }
  if (row_support_radius_px < 1 || row_support_radius_px > kMaxRowSupportRadius) {
    return fail("row_support_radius_px = " + std::to_string(row_support_radius_px) +
                "; must be in [1, 16]");
  }
  if (Status s = checkSimd("simd", simd); !s) return s;
  return Status::ok();
}

Status matchSalient(const ImageU8& left,
                    const ImageU8& right,
                    const std::vector<Corner>& corners,
                    const SalientSadOptions& options,
                    StereoHypotheses* out) {
  const Status status = checkInputs(left, right, options, out);
  if (!status.isOk()) return status;
  out->clear();
  out->points.reserve(corners.size());

  const Simd kernel = resolveSimd(options.simd);
  const int w = options.window_width_px;
  const int h = w / 2;
  const int m = options.row_tolerance_px;
  const int d_min = options.min_disparity_px;
  const int d_max = options.max_disparity_px;
  const int width = left.width;
  const int height = left.height;
  const int gate = costGate(options);
  const size_t max_k = static_cast<size_t>(options.max_hypotheses);
  // Window alignments, centred first (preferred on equal cost): ending at u, starting at u.
  const int alignments[3] = {0, -h, h};
  const int num_alignments = options.shiftable_windows ? 3 : 1;

  // Birchfield-Tomasi: forward curves read the right image's intervals, the right-to-left
  // check the left image's. Reused across calls on this thread (4 images' worth of bytes).
  thread_local ImageU8 intervals[4];
  StripSource forward{&right, nullptr, nullptr};
  StripSource backward{&left, nullptr, nullptr};
  if (options.birchfield_tomasi) {
    internal::samplingIntervals(right, &intervals[0], &intervals[1]);
    forward.lo = &intervals[0];
    forward.hi = &intervals[1];
    if (options.lr_check) {
      internal::samplingIntervals(left, &intervals[2], &intervals[3]);
      backward.lo = &intervals[2];
      backward.hi = &intervals[3];
    }
  }

  CurveScratch scratch;
  constexpr int kMaxCurves = (2 * kMaxRowTolerance + 1) * 3;
  std::vector<uint16_t> curve_storage(static_cast<size_t>(kMaxCurves) * kCurveStride);
  Curve curves[kMaxCurves];
  alignas(32) uint16_t back[kMaxPadded];
  alignas(32) uint16_t prefix[4][kMaxPadded];
  std::vector<Candidate> candidates;
  candidates.reserve(64);
  Candidate chosen[kMaxHypothesesLimit];

  for (const Corner& corner : corners) {
    const int u = corner.u_px;
    const int v = corner.v_px;
    if (u < h || u >= width - h || v < 0 || v >= height) continue;
    const auto point_index = static_cast<uint32_t>(out->points.size());
    SalientPoint point;
    point.corner = corner;
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());

    // One pass over the 2W-1 columns u-2h..u+2h gives all three alignments when they share
    // the full disparity range (plain SAD; zero-mean offsets differ per window).
    const bool fused =
        num_alignments == 3 && !options.zero_mean && u - 2 * h >= d_max && u + 2 * h < width;

    // Rows in the order 0, -1, +1, -2, +2, ... so that equal costs prefer small offsets.
    int num_curves = 0;
    int best = INT_MAX;
    // A window that does not fit or a curve cut short by the image border leaves disparities
    // unsearched: the hypotheses found are then not known to be all there are.
    bool cut_short = false;
    for (int ri = 0; ri <= 2 * m; ++ri) {
      const int r = (ri % 2 == 1) ? -(ri + 1) / 2 : ri / 2;
      if (v + r < 0 || v + r >= height) {
        cut_short = true;
        continue;
      }
      if (fused) {
        const int n = d_max - d_min + 1;
        const int span = 4 * h + 1;
        const auto need = static_cast<size_t>(internal::paddedLength(n, kernel) + span - 1);
        const int base = u - 2 * h - d_max;
        const uint8_t* strip =
            stripFor(forward.lo != nullptr ? *forward.lo : right, v + r, base, need, scratch.strip);
        const uint8_t* strip_hi = forward.hi == nullptr
                                      ? nullptr
                                      : stripFor(*forward.hi, v + r, base, need, scratch.strip_hi);
        Curve* centre = &curves[num_curves];
        Curve* ends_at_u = &curves[num_curves + 1];
        Curve* starts_at_u = &curves[num_curves + 2];
        for (int k = 0; k < 3; ++k) {
          Curve& curve = curves[num_curves + k];
          curve.row_offset_px = r;
          curve.align_px = alignments[k];
          curve.d_hi = d_max;
          curve.n = n;
          curve.cost =
              curve_storage.data() + static_cast<size_t>(num_curves + k) * kCurveStride + kGuard;
        }
        // Prefix ends: h, 2h, 2h+1 (= window ending at u), 3h+1, 4h+1.
        const int ends[5] = {h, 2 * h, 2 * h + 1, 3 * h + 1, 4 * h + 1};
        uint16_t* const outs[5] = {prefix[0], prefix[1], ends_at_u->cost, prefix[2], prefix[3]};
        internal::intervalPrefixCurves(
            kernel, left.row(v) + (u - 2 * h), strip, strip_hi, n, ends, 5, outs);
        for (int j = 0; j < n; ++j) {
          centre->cost[j] = static_cast<uint16_t>(prefix[2][j] - prefix[0][j]);
          starts_at_u->cost[j] = static_cast<uint16_t>(prefix[3][j] - prefix[1][j]);
        }
        for (int k = 0; k < 3; ++k) {
          setGuards(curves[num_curves + k].cost, n);
          best = std::min(best, minCost(curves[num_curves + k].cost, n));
        }
        num_curves += 3;
        continue;
      }
      for (int ai = 0; ai < num_alignments; ++ai) {
        const int a = alignments[ai];
        const int start = u + a - h;  // first column of the left window
        if (start < 0 || start + w > width) {
          cut_short = true;
          continue;
        }
        // Disparities whose right window starts left of column 0 are not searched.
        const int d_hi = std::min(d_max, start);
        if (d_hi < d_max) cut_short = true;
        if (d_hi < d_min) continue;
        Curve& curve = curves[num_curves];
        curve.row_offset_px = r;
        curve.align_px = a;
        curve.d_hi = d_hi;
        curve.n = d_hi - d_min + 1;
        curve.cost = curve_storage.data() + static_cast<size_t>(num_curves) * kCurveStride + kGuard;
        costCurve(kernel,
                  left.row(v) + start,
                  w,
                  forward,
                  v + r,
                  start - d_hi,
                  curve.n,
                  options.zero_mean,
                  &scratch,
                  curve.cost);
        setGuards(curve.cost, curve.n);
        // Cut short by the image border, the curve's end at d_hi is not a minimum of the
        // matching cost, only of what could be searched: the true disparity may lie beyond
        // (a corner nearer the left edge than its disparity). A zero guard keeps t = 0 from
        // ever passing the local-minimum test. Measured on the office world: such end points
        // were a quarter of the wrongly confirmed landmarks (d = u exactly, 1-2 px short).
        if (d_hi < d_max) curve.cost[-1] = 0;
        best = std::min(best, minCost(curve.cost, curve.n));
        ++num_curves;
      }
    }
    if (num_curves == 0 || best > gate) {
      out->points.push_back(point);
      continue;
    }
    const double ratio_limit = static_cast<double>(best) * options.cost_ratio;
    const int threshold = std::min(gate, static_cast<int>(std::min(ratio_limit, 1e9)));
    if (gate < ratio_limit) cut_short = true;  // max_cost_per_px hides minima within cost_ratio

    candidates.clear();
    for (int k = 0; k < num_curves; ++k) {
      const Curve& curve = curves[k];
      const uint16_t* c = curve.cost;
      forEachLocalMinimum(c, curve.n, threshold, [&](int t) {
        candidates.push_back({static_cast<int>(c[t]), curve.d_hi - t, t, k});
      });
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
      return cheaper(a, b);
    });

    size_t num_chosen = 0;
    bool dropped = false;  // a minimum that may be the real disparity is not in the list
    for (const Candidate& cand : candidates) {
      bool distinct = true;
      for (size_t k = 0; k < num_chosen; ++k) {
        if (std::abs(cand.d_px - chosen[k].d_px) < options.min_separation_px) {
          distinct = false;
          break;
        }
      }
      if (!distinct) continue;
      if (num_chosen == max_k) {
        dropped = true;  // no room in the list
        break;
      }
      chosen[num_chosen++] = cand;
    }
    if (!dropped && !cut_short && num_chosen >= 2) {
      // A periodic texture's real disparity may sit half a pixel off the grid, its aliases on
      // it, and cost up to complete_cost_ratio x the best (taken as at least 1 grey level per
      // pixel): a local minimum that cheap where the list's period continues (2 d_i - d_j,
      // within 1 px) and not in the list leaves it incomplete.
      const double complete_limit =
          static_cast<double>(std::max(best, w)) * options.complete_cost_ratio;
      const int limit = static_cast<int>(std::min(complete_limit, 1e9));
      if (gate < complete_limit) dropped = true;  // max_cost_per_px could hide it
      for (size_t i = 0; i < num_chosen && !dropped; ++i) {
        for (size_t j = 0; j < num_chosen && !dropped; ++j) {
          const int next = 2 * chosen[i].d_px - chosen[j].d_px;
          if (i == j || next + 1 < d_min || next - 1 > d_max) continue;
          bool listed = false;
          for (size_t k = 0; k < num_chosen; ++k)
            listed = listed || std::abs(chosen[k].d_px - next) <= 1;
          if (listed) continue;
          for (int k = 0; k < num_curves && !dropped; ++k) {
            const Curve& curve = curves[k];
            const uint16_t* c = curve.cost;
            for (int d = next - 1; d <= next + 1 && !dropped; ++d) {
              const int t = curve.d_hi - d;  // cost index of disparity d
              if (t < 0 || t >= curve.n) continue;
              dropped = c[t] <= limit && c[t] < c[t - 1] && c[t] <= c[t + 1];
            }
          }
        }
      }
    }
    point.complete = !dropped && !cut_short;

    for (size_t k = 0; k < num_chosen; ++k) {
      const Candidate& cand = chosen[k];
      const Curve& curve = curves[cand.curve];
      const uint16_t* c = curve.cost;
      float offset = 0.0f;
      if (cand.t > 0 && cand.t + 1 < curve.n) {
        // c[t + 1] is disparity d - 1, c[t - 1] is d + 1.
        offset = parabolaOffset(c[cand.t + 1], c[cand.t], c[cand.t - 1]);
      }
      DisparityHypothesis hyp;
      hyp.d_px = static_cast<float>(cand.d_px) + offset;
      hyp.cost = static_cast<float>(cand.cost);
      hyp.point_index = point_index;
      hyp.row_offset_px = static_cast<int8_t>(curve.row_offset_px);
      hyp.window_shift_px = static_cast<int8_t>(curve.align_px);
      hyp.rank = static_cast<uint8_t>(k);
      if (options.lr_check) {
        // The right window (same alignment) at u - d on row v + r, searched along left row v:
        // back curve index t <-> disparity d_min + t.
        const int right_start = u - cand.d_px + curve.align_px - h;
        const int back_hi = std::min(d_max, width - w - right_start);
        const int back_n = back_hi - d_min + 1;
        costCurve(kernel,
                  right.row(v + curve.row_offset_px) + right_start,
                  w,
                  backward,
                  v,
                  right_start + d_min,
                  back_n,
                  options.zero_mean,
                  &scratch,
                  back);
        const int t_lo = std::max(0, cand.d_px - options.lr_tolerance_px - d_min);
        const int t_hi = std::min(back_n - 1, cand.d_px + options.lr_tolerance_px - d_min);
        int near_best = INT_MAX;
        for (int t = t_lo; t <= t_hi; ++t)
          near_best = std::min(near_best, static_cast<int>(back[t]));
        hyp.lr_consistent = near_best == minCost(back, back_n);
      }
      out->hypotheses.push_back(hyp);
    }
    point.num_hypotheses = static_cast<uint32_t>(num_chosen);
    out->points.push_back(point);
  }
  return Status::ok();
}

const DisparityHypothesis* confidentBest(const StereoHypotheses& hyps,
                                         const SalientPoint& point,
                                         float agree_px) {
  if (point.num_hypotheses == 0) return nullptr;
  TWOCAM_CHECK(static_cast<size_t>(point.first_hypothesis) + point.num_hypotheses <=
               hyps.hypotheses.size())
      << "point's hypotheses [" << point.first_hypothesis << ", +" << point.num_hypotheses
      << ") outside the " << hyps.hypotheses.size() << " of this StereoHypotheses";
  const DisparityHypothesis* first = &hyps.hypotheses[point.first_hypothesis];
  if (!first->lr_consistent) return nullptr;
  for (uint32_t k = 1; k < point.num_hypotheses; ++k) {
    if (first[k].lr_consistent && std::abs(first[k].d_px - first->d_px) > agree_px) {
      return nullptr;
    }
  }
  return first;
}

}  // namespace twocam::frontend
