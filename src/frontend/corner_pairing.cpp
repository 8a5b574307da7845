#include "frontend/corner_pairing.h"

#include <algorithm>
#include <climits>
#include <cstdlib>

#include "frontend/cost_curve.h"

namespace twocam::frontend {

using internal::checkInputs;
using internal::costGate;
using internal::windowCost;

Status pairCorners(const ImageU8& left,
                   const ImageU8& right,
                   const std::vector<Corner>& left_corners,
                   const std::vector<Corner>& right_corners,
                   const SalientSadOptions& options,
                   StereoHypotheses* out) {
  const Status status = checkInputs(left, right, options, out);
  if (!status.isOk()) return status;
  out->clear();
  out->points.reserve(left_corners.size());

  const int w = options.window_width_px;
  const int h = w / 2;
  const int m = options.row_tolerance_px;
  const int width = left.width;
  const int height = left.height;
  const int gate = costGate(options);

  // Row index of the right corners whose window fits: row_begin[v]..row_begin[v + 1] in
  // `by_row`, sorted by column.
  std::vector<uint32_t> row_begin(static_cast<size_t>(height) + 1, 0);
  for (const Corner& c : right_corners) {
    if (c.u_px >= h && c.u_px < width - h && c.v_px >= 0 && c.v_px < height) {
      ++row_begin[static_cast<size_t>(c.v_px) + 1];
    }
  }
  for (int v = 0; v < height; ++v) row_begin[v + 1] += row_begin[v];
  std::vector<uint32_t> by_row(row_begin[height]);
  {
    std::vector<uint32_t> fill(row_begin.begin(), row_begin.end() - 1);
    for (size_t i = 0; i < right_corners.size(); ++i) {
      const Corner& c = right_corners[i];
      if (c.u_px >= h && c.u_px < width - h && c.v_px >= 0 && c.v_px < height) {
        by_row[fill[c.v_px]++] = static_cast<uint32_t>(i);
      }
    }
  }
  auto column_less = [&right_corners](uint32_t a, uint32_t b) {
    return right_corners[a].u_px < right_corners[b].u_px ||
           (right_corners[a].u_px == right_corners[b].u_px && a < b);
  };
  for (int v = 0; v < height; ++v) {
    std::sort(by_row.begin() + row_begin[v], by_row.begin() + row_begin[v + 1], column_less);
  }

  struct Pair {
    int cost;
    int d_px;
    int row_offset_px;
    uint32_t right_index;
  };
  std::vector<Pair> pairs;
  std::vector<uint32_t> pair_begin;  // per point, into pairs
  pair_begin.reserve(left_corners.size() + 1);
  std::vector<int> right_best(right_corners.size(), INT_MAX);

  for (const Corner& corner : left_corners) {
    const int u = corner.u_px;
    const int v = corner.v_px;
    if (u < h || u >= width - h || v < 0 || v >= height) continue;
    pair_begin.push_back(static_cast<uint32_t>(pairs.size()));
    SalientPoint point;
    point.corner = corner;
    out->points.push_back(point);
    const uint8_t* win = left.row(v) + (u - h);
    const int u_lo = u - options.max_disparity_px;
    const int u_hi = u - options.min_disparity_px;
    for (int r = -m; r <= m; ++r) {
      const int vr = v + r;
      if (vr < 0 || vr >= height) continue;
      const auto first = by_row.begin() + row_begin[vr];
      const auto last = by_row.begin() + row_begin[vr + 1];
      auto it = std::lower_bound(first, last, u_lo, [&right_corners](uint32_t i, int col) {
        return right_corners[i].u_px < col;
      });
      for (; it != last && right_corners[*it].u_px <= u_hi; ++it) {
        const int ur = right_corners[*it].u_px;
        int cost = windowCost(win, right.row(vr) + (ur - h), w, options.zero_mean);
        if (options.shiftable_windows) {
          for (const int a : {-h, h}) {
            if (std::min(u, ur) + a - h < 0 || std::max(u, ur) + a + h >= width) continue;
            cost = std::min(
                cost,
                windowCost(
                    left.row(v) + (u + a - h), right.row(vr) + (ur + a - h), w, options.zero_mean));
          }
        }
        pairs.push_back({cost, u - ur, r, *it});
        right_best[*it] = std::min(right_best[*it], cost);
      }
    }
  }
  pair_begin.push_back(static_cast<uint32_t>(pairs.size()));

  auto pair_less = [](const Pair& a, const Pair& b) {
    if (a.cost != b.cost) return a.cost < b.cost;
    if (a.d_px != b.d_px) return a.d_px < b.d_px;
    if (std::abs(a.row_offset_px) != std::abs(b.row_offset_px)) {
      return std::abs(a.row_offset_px) < std::abs(b.row_offset_px);
    }
    return a.row_offset_px < b.row_offset_px;
  };
  for (size_t p = 0; p < out->points.size(); ++p) {
    const auto first = pairs.begin() + pair_begin[p];
    const auto last = pairs.begin() + pair_begin[p + 1];
    const auto kept_end =
        std::partition(first, last, [gate](const Pair& pr) { return pr.cost <= gate; });
    const auto count = std::min<std::ptrdiff_t>(kept_end - first, options.max_hypotheses);
    std::partial_sort(first, first + count, kept_end, pair_less);
    SalientPoint& point = out->points[p];
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());
    point.num_hypotheses = static_cast<uint32_t>(count);
    for (std::ptrdiff_t k = 0; k < count; ++k) {
      const Pair& pr = first[k];
      DisparityHypothesis hyp;
      hyp.d_px = static_cast<float>(pr.d_px);
      hyp.cost = static_cast<float>(pr.cost);
      hyp.point_index = static_cast<uint32_t>(p);
      hyp.row_offset_px = static_cast<int8_t>(pr.row_offset_px);
      hyp.rank = static_cast<uint8_t>(k);
      hyp.lr_consistent = options.lr_check && pr.cost == right_best[pr.right_index];
      out->hypotheses.push_back(hyp);
    }
  }
  return Status::ok();
}

}  // namespace twocam::frontend
