#include "frontend/support_value.h"
/// Support-value matching at salient points (matchSupportValueSalient, support_value.h).

#include <algorithm>
#include <cstdlib>

#include "frontend/support_value_internal.h"

namespace twocam::frontend {

// The matcher's pieces (support_value_internal.h) by their short names.
using namespace internal::support;

// ---------------------------------------------------------------------------------------------
// Salient points.

Status matchSupportValueSalient(const ImageU8& left,
                                const ImageU8& right,
                                const std::vector<Corner>& corners,
                                const SupportValueOptions& options,
                                StereoHypotheses* out) {
  if (out == nullptr) return Status::error("support value: out is null");
  if (Status s = checkInputs(left, right, options); !s) return s;

  const Geometry g = makeGeometry(left.width, left.height, options);
  const WeightPlanes planes = makePlanes(options);
  const Kernels kernels = kernelsFor(options.simd);
  std::vector<uint8_t> left_pad, right_pad;
  padImage(left, g, &left_pad);
  padImage(right, g, &right_pad);

  const size_t words = static_cast<size_t>(g.words);
  std::vector<uint64_t> anchor(words);
  std::vector<uint64_t> others(static_cast<size_t>(g.nd) * words);
  std::vector<int32_t> sv(static_cast<size_t>(g.nd));
  std::vector<int32_t> back(static_cast<size_t>(g.nd));
  const float min_corr = static_cast<float>(options.min_correlation);

  // Structures of the windows of `pad` on row v at columns x0 + sign * k, k in [0, count); their
  // sums slide along the row over column sums of the window rows (no integral image: a call
  // touches only the corners' rows).
  std::vector<int32_t> column_sums;
  auto structures_along = [&](const std::vector<uint8_t>& pad, int x0, int sign, int count, int v) {
    if (count <= 0) return;
    const int first = sign > 0 ? x0 : x0 - count + 1;  // leftmost window
    const int span = count + g.win - 1;
    column_sums.assign(static_cast<size_t>(span), 0);
    for (int i = 0; i < g.win; ++i) {
      const uint8_t* row = pad.data() + static_cast<size_t>(v + i) * g.wp + first;
      for (int x = 0; x < span; ++x) column_sums[static_cast<size_t>(x)] += row[x];
    }
    int64_t sum = 0;
    for (int x = 0; x < g.win; ++x) sum += column_sums[static_cast<size_t>(x)];
    for (int j = 0; j < count; ++j) {  // window first + j
      if (j > 0) {
        sum += column_sums[static_cast<size_t>(j + g.win - 1)] -
               column_sums[static_cast<size_t>(j - 1)];
      }
      const int k = sign > 0 ? j : count - 1 - j;
      kernels.structure(
          pad.data(), g, first + j, v, sum, others.data() + static_cast<size_t>(k) * words);
    }
  };

  struct Scored {
    int d;
    float r;
  };
  out->clear();
  for (const Corner& c : corners) {
    const int u = c.u_px;
    const int v = c.v_px;
    if (u < 0 || u >= g.width || v < 0 || v >= g.height) continue;
    SalientPoint point;
    point.corner = c;
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());
    const uint32_t point_index = static_cast<uint32_t>(out->points.size());
    const int count = u < g.dmin ? 0 : std::min(g.nd, u - g.dmin + 1);
    const bool cut_short = count < g.nd;
    const WindowStats ls = directStats(left_pad, g, u, v);
    kernels.structure(left_pad.data(), g, u, v, ls.sum, anchor.data());
    // Right windows at u - dmin - k.
    structures_along(right_pad, u - g.dmin, -1, count, v);
    for (int k = 0; k < count; ++k) {
      sv[static_cast<size_t>(k)] = static_cast<int32_t>(
          planes.total -
          kernels.disagreement(anchor.data(), others.data() + k * words, g.words, planes));
    }
    int cand[kMaxCandidates];
    bool dropped = false;
    const int max_list = std::min(kMaxCandidates, options.max_hypotheses);
    const int n =
        selectCandidates(sv.data(), 1, count, options.hypothesis_margin, max_list, cand, &dropped);
    Scored scored[kMaxCandidates];
    int kept = 0;
    for (int q = 0; q < n; ++q) {
      const int d = g.dmin + cand[q];
      const float r = correlation(crossSum(left_pad.data(), right_pad.data(), g, u, u - d, v),
                                  ls,
                                  directStats(right_pad, g, u - d, v),
                                  g.n);
      if (r >= min_corr) scored[kept++] = {d, r};
    }
    std::stable_sort(
        scored, scored + kept, [](const Scored& a, const Scored& b) { return a.r > b.r; });
    for (int q = 0; q < kept; ++q) {
      DisparityHypothesis h;
      h.d_px = static_cast<float>(scored[q].d);
      h.cost = 1.0f - scored[q].r;
      h.point_index = point_index;
      h.rank = static_cast<uint8_t>(q);
      if (options.lr_tolerance_px >= 0) {
        // Right window at u_r matched back along the left row: left windows at u_r + dmin + k.
        const int u_r = u - scored[q].d;
        const WindowStats rs = directStats(right_pad, g, u_r, v);
        uint64_t right_anchor[kMaxWords];
        kernels.structure(right_pad.data(), g, u_r, v, rs.sum, right_anchor);
        const int back_count = std::min(g.nd, g.width - u_r - g.dmin);
        structures_along(left_pad, u_r + g.dmin, +1, back_count, v);
        for (int k = 0; k < back_count; ++k) {
          back[static_cast<size_t>(k)] = static_cast<int32_t>(
              planes.total -
              kernels.disagreement(right_anchor, others.data() + k * words, g.words, planes));
        }
        int back_cand[kMaxCandidates];
        bool back_dropped = false;
        const int nb = selectCandidates(back.data(),
                                        1,
                                        back_count,
                                        options.candidate_margin,
                                        options.max_candidates,
                                        back_cand,
                                        &back_dropped);
        float best = kNoCorrelation;
        int best_d = kNoMatch;
        for (int b = 0; b < nb; ++b) {
          const int d = g.dmin + back_cand[b];
          const float r =
              correlation(crossSum(left_pad.data(), right_pad.data(), g, u_r + d, u_r, v),
                          directStats(left_pad, g, u_r + d, v),
                          rs,
                          g.n);
          if (r > best) {
            best = r;
            best_d = d;
          }
        }
        h.lr_consistent = best_d >= 0 && best >= min_corr &&
                          std::abs(best_d - scored[q].d) <= options.lr_tolerance_px;
      }
      out->hypotheses.push_back(h);
    }
    point.num_hypotheses = static_cast<uint32_t>(kept);
    point.complete = !dropped && !cut_short;
    out->points.push_back(point);
  }
  return Status::ok();
}

}  // namespace twocam::frontend
