#include "frontend/maxtree.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "frontend/dense_sad.h"  // kNoDisparity

namespace twocam::frontend {

namespace {

/// 2^b of Eq. 3 for 8-bit images.
constexpr float kContextScale = 256.0f;
constexpr int kMaxLevel = 8;
constexpr int kMaxNeighbourhood = 64;
constexpr int kMaxOutlierWindowPx = 101;
constexpr int kMaxCornerRadiusPx = 16;
constexpr int kMaxDisparityPx = 2047;

int clampIndex(int i, int n) { return i < 0 ? 0 : (i >= n ? n - 1 : i); }

int upperMedian(int* values, int count) {
  std::nth_element(values, values + count / 2, values + count);
  return values[count / 2];
}

}  // namespace

Status MaxTreeOptions::validate() const {
  std::ostringstream msg;
  if (max_disparity_px < 1 || max_disparity_px > kMaxDisparityPx) {
    msg << "max_disparity_px = " << max_disparity_px << "; must be in [1, " << kMaxDisparityPx
        << "]";
  } else if (quantization_levels < 1 || quantization_levels > 256) {
    msg << "quantization_levels = " << quantization_levels << "; must be in [1, 256]";
  } else if (levels.empty()) {
    msg << "levels is empty; must list at least one top-node level";
  } else if (neighbourhood_nodes < 0 || neighbourhood_nodes > kMaxNeighbourhood) {
    msg << "neighbourhood_nodes = " << neighbourhood_nodes << "; must be in [0, "
        << kMaxNeighbourhood << "]";
  } else if (!(gradient_weight >= 0.0f && gradient_weight <= 1.0f)) {
    msg << "gradient_weight = " << gradient_weight << "; must be in [0, 1]";
  } else if (min_node_width_px < 0) {
    msg << "min_node_width_px = " << min_node_width_px << "; must be >= 0";
  } else if (max_node_width_px < 0) {
    msg << "max_node_width_px = " << max_node_width_px << "; must be >= 0 (0 = width / 3)";
  } else if (sobel_size_px != 3 && sobel_size_px != 5) {
    msg << "sobel_size_px = " << sobel_size_px << "; must be 3 or 5";
  } else if (similarity_px < 0) {
    msg << "similarity_px = " << similarity_px << "; must be >= 0";
  } else if (outlier_window_px < 3 || outlier_window_px > kMaxOutlierWindowPx ||
             outlier_window_px % 2 == 0) {
    msg << "outlier_window_px = " << outlier_window_px << "; must be odd and in [3, "
        << kMaxOutlierWindowPx << "]";
  } else if (corner_radius_px < 0 || corner_radius_px > kMaxCornerRadiusPx) {
    msg << "corner_radius_px = " << corner_radius_px << "; must be in [0, " << kMaxCornerRadiusPx
        << "]";
  } else if (max_hypotheses < 1 || max_hypotheses > 255) {
    msg << "max_hypotheses = " << max_hypotheses << "; must be in [1, 255]";
  } else if (!(cost_ratio >= 1.0f) || !std::isfinite(cost_ratio)) {
    msg << "cost_ratio = " << cost_ratio << "; must be finite and >= 1";
  } else {
    for (size_t i = 0; i < levels.size(); ++i) {
      if (levels[i] < 0 || levels[i] > kMaxLevel) {
        msg << "levels[" << i << "] = " << levels[i] << "; must be in [0, " << kMaxLevel << "]";
        break;
      }
      if (i > 0 && levels[i] >= levels[i - 1]) {
        msg << "levels[" << i << "] = " << levels[i] << "; must be below levels[" << i - 1
            << "] = " << levels[i - 1] << " (coarse to fine, strictly decreasing)";
        break;
      }
    }
  }
  const std::string text = msg.str();
  return text.empty() ? Status::ok() : Status::error("MaxTreeOptions: " + text);
}

void medianFilter5x5(const ImageU8& image, ImageU8* out) {
  // Sliding histogram along each row (Huang et al. 1979): 5 values leave and 5 enter per pixel,
  // and the median moves from its previous position; `below` counts window values < median.
  constexpr int kRank = 12;  // 13th smallest of 25
  const int w = image.width;
  const int h = image.height;
  *out = ImageU8(w, h);
  std::array<int, 256> hist{};
  for (int v = 0; v < h; ++v) {
    std::array<const uint8_t*, 5> rows{};
    for (int k = 0; k < 5; ++k) rows[k] = image.row(clampIndex(v + k - 2, h));
    hist.fill(0);
    for (int j = -2; j <= 2; ++j) {
      const int x = clampIndex(j, w);
      for (int k = 0; k < 5; ++k) hist[rows[k][x]]++;
    }
    int median = 0;
    int below = 0;
    while (below + hist[median] <= kRank) below += hist[median++];
    uint8_t* dst = out->row(v);
    dst[0] = static_cast<uint8_t>(median);
    for (int u = 1; u < w; ++u) {
      const int gone = clampIndex(u - 3, w);
      const int come = clampIndex(u + 2, w);
      for (int k = 0; k < 5; ++k) {
        const int a = rows[k][gone];
        const int b = rows[k][come];
        hist[a]--;
        if (a < median) below--;
        hist[b]++;
        if (b < median) below++;
      }
      while (below > kRank) below -= hist[--median];
      while (below + hist[median] <= kRank) below += hist[median++];
      dst[u] = static_cast<uint8_t>(median);
    }
  }
}

Status invertedGradientImage(const ImageU8& smoothed,
                             int quantization_levels,
                             int sobel_size_px,
                             ImageU8* g,
                             Image<int16_t>* sx,
                             Image<int16_t>* sy) {
  if (smoothed.empty() || smoothed.width <= 0 || smoothed.height <= 0)
    return Status::error("invertedGradientImage: empty image");
  if (quantization_levels < 1 || quantization_levels > 256) {
    return Status::error("invertedGradientImage: quantization_levels = " +
                         std::to_string(quantization_levels) + "; must be in [1, 256]");
  }
  if (sobel_size_px != 3 && sobel_size_px != 5) {
    return Status::error("invertedGradientImage: sobel_size_px = " + std::to_string(sobel_size_px) +
                         "; must be 3 or 5");
  }
  const int w = smoothed.width;
  const int h = smoothed.height;
  // Separable Sobel: 3x3 derivative [-1 0 1], smoothing [1 2 1]; 5x5 [-1 -2 0 2 1], [1 4 6 4 1].
  const int taps = sobel_size_px;
  const int half = taps / 2;
  const std::array<int, 5> deriv =
      taps == 3 ? std::array<int, 5>{-1, 0, 1, 0, 0} : std::array<int, 5>{-1, -2, 0, 2, 1};
  const std::array<int, 5> smooth =
      taps == 3 ? std::array<int, 5>{1, 2, 1, 0, 0} : std::array<int, 5>{1, 4, 6, 4, 1};
  Image<int32_t> hd(w, h);
  Image<int32_t> hs(w, h);
  for (int v = 0; v < h; ++v) {
    const uint8_t* src = smoothed.row(v);
    for (int u = 0; u < w; ++u) {
      int d = 0;
      int s = 0;
      for (int k = 0; k < taps; ++k) {
        const int p = src[clampIndex(u + k - half, w)];
        d += deriv[k] * p;
        s += smooth[k] * p;
      }
      hd(u, v) = d;
      hs(u, v) = s;
    }
  }
  *sx = Image<int16_t>(w, h);
  *sy = Image<int16_t>(w, h);
  *g = ImageU8(w, h);
  const int band = 256 / quantization_levels;
  for (int v = 0; v < h; ++v) {
    std::array<const int32_t*, 5> d_rows{};
    std::array<const int32_t*, 5> s_rows{};
    for (int k = 0; k < taps; ++k) {
      d_rows[k] = hd.row(clampIndex(v + k - half, h));
      s_rows[k] = hs.row(clampIndex(v + k - half, h));
    }
    for (int u = 0; u < w; ++u) {
      int gx = 0;
      int gy = 0;
      for (int k = 0; k < taps; ++k) {
        gx += smooth[k] * d_rows[k][u];
        gy += deriv[k] * s_rows[k][u];
      }
      (*sx)(u, v) = static_cast<int16_t>(gx);  // |gx| <= 255 * 48 fits
      (*sy)(u, v) = static_cast<int16_t>(gy);
      const int inverted = 255 - (std::abs(gx) + std::abs(gy)) / 2;
      const int stretched = std::clamp((inverted - 127) * 255 / 128, 0, 255);
      (*g)(u, v) = static_cast<uint8_t>(std::min(255, (stretched / band) * band));
    }
  }
  return Status::ok();
}

void buildRowMaxTree(const uint8_t* g,
                     int width,
                     std::vector<MaxTreeNode>* nodes,
                     int32_t* pixel_node) {
  nodes->clear();
  std::vector<int32_t> stack;
  stack.reserve(257);
  auto open = [&](int level, int left) {
    MaxTreeNode n;
    n.level = static_cast<uint8_t>(level);
    n.left_px = left;
    nodes->push_back(n);
    stack.push_back(static_cast<int32_t>(nodes->size() - 1));
  };
  for (int x = 0; x < width; ++x) {
    const int value = g[x];
    while (!stack.empty() && (*nodes)[stack.back()].level > value) {
      const int32_t top = stack.back();
      stack.pop_back();
      (*nodes)[top].right_px = x - 1;
      if (stack.empty() || (*nodes)[stack.back()].level < value) {
        // The component at `value` that contains the closed one starts where it started.
        open(value, (*nodes)[top].left_px);
      }
      (*nodes)[top].parent = stack.back();
      (*nodes)[stack.back()].num_children++;
    }
    if (stack.empty() || (*nodes)[stack.back()].level < value) open(value, x);
    pixel_node[x] = stack.back();
  }
  while (!stack.empty()) {
    const int32_t top = stack.back();
    stack.pop_back();
    (*nodes)[top].right_px = width - 1;
    if (!stack.empty()) {
      (*nodes)[top].parent = stack.back();
      (*nodes)[stack.back()].num_children++;
    }
  }
  // Depth: parents can come after their children in creation order, so walk up with memo.
  std::vector<int32_t> depth(nodes->size(), -1);
  std::vector<int32_t> path;
  for (size_t i = 0; i < nodes->size(); ++i) {
    auto n = static_cast<int32_t>(i);
    path.clear();
    while (n >= 0 && depth[n] < 0) {
      path.push_back(n);
      n = (*nodes)[n].parent;
    }
    int d = n >= 0 ? depth[n] : -1;
    for (auto it = path.rbegin(); it != path.rend(); ++it) depth[*it] = ++d;
  }
  for (size_t i = 0; i < nodes->size(); ++i) (*nodes)[i].depth = depth[i];
}

void markTopNodes(int min_width_px,
                  int max_width_px,
                  int max_level,
                  std::vector<MaxTreeNode>* nodes) {
  std::vector<MaxTreeNode>& ns = *nodes;
  for (MaxTreeNode& n : ns) {
    n.top_level = -1;
    if (n.num_children == 0 && n.width() > min_width_px && n.width() < max_width_px)
      n.top_level = 0;
  }
  std::vector<uint8_t> candidate(ns.size());
  std::vector<uint8_t> blocked(ns.size());
  for (int level = 1; level <= max_level; ++level) {
    std::fill(candidate.begin(), candidate.end(), 0);
    std::fill(blocked.begin(), blocked.end(), 0);
    bool any = false;
    for (const MaxTreeNode& n : ns) {
      if (n.top_level == level - 1 && n.parent >= 0) {
        candidate[n.parent] = 1;
        any = true;
      }
    }
    if (!any) break;
    // A candidate with a candidate below it is not a top node of this level.
    for (size_t i = 0; i < ns.size(); ++i) {
      if (candidate[i] == 0) continue;
      for (int32_t a = ns[i].parent; a >= 0 && blocked[a] == 0; a = ns[a].parent) blocked[a] = 1;
    }
    for (size_t i = 0; i < ns.size(); ++i) {
      if (candidate[i] != 0 && blocked[i] == 0 && ns[i].top_level < 0)
        ns[i].top_level = static_cast<int8_t>(level);
    }
  }
}

void MaxTreeMatcher::buildView(const ImageU8& image,
                               const MaxTreeOptions& options,
                               int max_width,
                               View* view) {
  const int w = image.width;
  const int h = image.height;
  medianFilter5x5(image, &view->smoothed);
  // Options were validated: q is in range and the image is not empty.
  (void)invertedGradientImage(view->smoothed,
                              options.quantization_levels,
                              options.sobel_size_px,
                              &view->g,
                              &view->sx,
                              &view->sy);
  view->nodes.clear();
  view->node_row.clear();
  view->row_first.assign(static_cast<size_t>(h) + 1, 0);
  view->pixel_node.resize(static_cast<size_t>(w) * h);
  const int max_level = *std::max_element(options.levels.begin(), options.levels.end());
  std::vector<MaxTreeNode> row_nodes;
  row_nodes.reserve(static_cast<size_t>(w));
  for (int v = 0; v < h; ++v) {
    int32_t* pixel = view->pixel_node.data() + static_cast<size_t>(v) * w;
    buildRowMaxTree(view->g.row(v), w, &row_nodes, pixel);
    markTopNodes(options.min_node_width_px, max_width, max_level, &row_nodes);
    const auto offset = static_cast<int32_t>(view->nodes.size());
    view->row_first[v] = offset;
    for (MaxTreeNode n : row_nodes) {
      if (n.parent >= 0) n.parent += offset;
      view->nodes.push_back(n);
      view->node_row.push_back(v);
    }
    for (int x = 0; x < w; ++x) pixel[x] += offset;
  }
  view->row_first[h] = static_cast<int32_t>(view->nodes.size());
  const size_t n = view->nodes.size();
  view->best.assign(n, -1);
  view->best_cost.assign(n, 0.0f);
  view->matched.assign(n, 0);
  view->d_left.assign(n, 0);
  view->d_right.assign(n, 0);
}

namespace {

/// The chain of `level` top nodes crossing the centre of the previous one, `dir` = -1 upwards
/// (rows above) or +1 downwards, at most k; returns its length, fills out[0..length).
int neighbourChain(const std::vector<MaxTreeNode>& nodes,
                   const std::vector<int32_t>& node_row,
                   const std::vector<int32_t>& pixel_node,
                   int width,
                   int height,
                   int32_t node,
                   int level,
                   int dir,
                   int k,
                   int32_t* out) {
  int count = 0;
  int32_t cur = node;
  int v = node_row[node];
  while (count < k) {
    v += dir;
    if (v < 0 || v >= height) break;
    const int centre = (nodes[cur].left_px + nodes[cur].right_px) / 2;
    int32_t m = pixel_node[static_cast<size_t>(v) * width + centre];
    while (m >= 0 && nodes[m].top_level != level) m = nodes[m].parent;
    if (m < 0) break;
    out[count++] = m;
    cur = m;
  }
  return count;
}

}  // namespace

void MaxTreeMatcher::prepareLevel(int level, int max_width, int k, View* view) const {
  const int w = width_;
  const int h = height_;
  view->sorted.clear();
  view->sorted_first.assign(static_cast<size_t>(h) + 1, 0);
  view->up.assign(view->nodes.size() * static_cast<size_t>(k), -1);
  view->down.assign(view->nodes.size() * static_cast<size_t>(k), -1);
  for (int v = 0; v < h; ++v) {
    view->sorted_first[v] = static_cast<int32_t>(view->sorted.size());
    for (int32_t i = view->row_first[v]; i < view->row_first[v + 1]; ++i) {
      const MaxTreeNode& n = view->nodes[i];
      if (n.top_level != level) continue;
      if (k > 0) {
        neighbourChain(view->nodes,
                       view->node_row,
                       view->pixel_node,
                       w,
                       h,
                       i,
                       level,
                       -1,
                       k,
                       view->up.data() + static_cast<size_t>(i) * k);
        neighbourChain(view->nodes,
                       view->node_row,
                       view->pixel_node,
                       w,
                       h,
                       i,
                       level,
                       +1,
                       k,
                       view->down.data() + static_cast<size_t>(i) * k);
      }
      // Nodes touching the image border, or too wide, are not matched (paper §2.2.1, §2.4).
      if (n.width() >= max_width || n.left_px == 0 || n.right_px == w - 1) continue;
      view->sorted.push_back(i);
    }
    std::sort(view->sorted.begin() + view->sorted_first[v],
              view->sorted.end(),
              [&](int32_t a, int32_t b) {
                return view->nodes[a].left_px < view->nodes[b].left_px ||
                       (view->nodes[a].left_px == view->nodes[b].left_px && a < b);
              });
  }
  view->sorted_first[h] = static_cast<int32_t>(view->sorted.size());
}

float MaxTreeMatcher::pairCost(
    const MaxTreeOptions& options, const View& lv, const View& rv, int32_t nl, int32_t nr) const {
  const int k = neighbourhood_;
  const float alpha = options.gradient_weight;
  auto node_cost = [&](int32_t a, int32_t b) {
    const MaxTreeNode& na = lv.nodes[a];
    const MaxTreeNode& nb = rv.nodes[b];
    const int v = lv.node_row[a];
    const int16_t* sxl = lv.sx.row(v);
    const int16_t* syl = lv.sy.row(v);
    const int16_t* sxr = rv.sx.row(v);
    const int16_t* syr = rv.sy.row(v);
    const int grad = std::abs(sxl[na.left_px] - sxr[nb.left_px]) +
                     std::abs(sxl[na.right_px] - sxr[nb.right_px]) +
                     std::abs(syl[na.left_px] - syr[nb.left_px]) +
                     std::abs(syl[na.right_px] - syr[nb.right_px]);
    // Eq. 3: mean over the two ancestor chains, walked in step up to the nearer root.
    float sum = 0.0f;
    int terms = 0;
    for (int32_t x = a, y = b; x >= 0 && y >= 0; x = lv.nodes[x].parent, y = rv.nodes[y].parent) {
      const auto wx = static_cast<float>(lv.nodes[x].width());
      const auto wy = static_cast<float>(rv.nodes[y].width());
      sum += std::fabs(wx / (wx + wy) - 0.5f);
      ++terms;
    }
    const float context = kContextScale * sum / static_cast<float>(terms);
    return alpha * static_cast<float>(grad) + (1.0f - alpha) * context;
  };
  const float self = node_cost(nl, nr);
  float total = 0.0f;
  for (int s = 0; s < 2; ++s) {
    const int32_t* cl = (s == 0 ? lv.up : lv.down).data() + static_cast<size_t>(nl) * k;
    const int32_t* cr = (s == 0 ? rv.up : rv.down).data() + static_cast<size_t>(nr) * k;
    float sum = self;
    int terms = 1;
    for (int i = 0; i < k && cl[i] >= 0 && cr[i] >= 0; ++i) {
      sum += node_cost(cl[i], cr[i]);
      ++terms;
    }
    total += sum / static_cast<float>(terms);
  }
  return total;
}

void MaxTreeMatcher::medianDisparity(
    const View& view, int32_t node, int k, int* dl, int* dr) const {
  std::array<int32_t, kMaxNeighbourhood> chain{};
  std::array<int, 2 * kMaxNeighbourhood + 1> ls{};
  std::array<int, 2 * kMaxNeighbourhood + 1> rs{};
  int count = 0;
  auto add = [&](int32_t n) {
    if (view.matched[n] == 0) return;
    ls[count] = view.d_left[n];
    rs[count] = view.d_right[n];
    ++count;
  };
  add(node);
  const int level = view.nodes[node].top_level;
  for (int dir = -1; dir <= 1; dir += 2) {
    const int len = neighbourChain(view.nodes,
                                   view.node_row,
                                   view.pixel_node,
                                   width_,
                                   height_,
                                   node,
                                   level,
                                   dir,
                                   k,
                                   chain.data());
    for (int i = 0; i < len; ++i) add(chain[i]);
  }
  // node itself is matched (callers ensure it), so count >= 1.
  *dl = upperMedian(ls.data(), count);
  *dr = upperMedian(rs.data(), count);
}

void MaxTreeMatcher::matchLevel(int level_index,
                                const MaxTreeOptions& options,
                                int sign,
                                const View& from,
                                const View& to,
                                std::vector<int32_t>* best,
                                std::vector<float>* best_cost,
                                int64_t* candidates) const {
  const int prev_level = level_index > 0 ? options.levels[level_index - 1] : -1;
  const int max_d = options.max_disparity_px;
  const int k = neighbourhood_;
  for (int v = 0; v < height_; ++v) {
    const int32_t* to_begin = to.sorted.data() + to.sorted_first[v];
    const int32_t* to_end = to.sorted.data() + to.sorted_first[v + 1];
    for (int32_t si = from.sorted_first[v]; si < from.sorted_first[v + 1]; ++si) {
      const int32_t n = from.sorted[si];
      const MaxTreeNode& node = from.nodes[n];
      // Eq. 5: later levels search inside the region their matched coarse ancestor maps to.
      int lo = std::numeric_limits<int>::min();
      int hi = std::numeric_limits<int>::max();
      if (prev_level >= 0) {
        int32_t ctn = node.parent;
        while (ctn >= 0 && from.nodes[ctn].top_level != prev_level) ctn = from.nodes[ctn].parent;
        if (ctn < 0 || from.matched[ctn] == 0) continue;
        int dl = 0;
        int dr = 0;
        medianDisparity(from, ctn, k, &dl, &dr);
        lo = from.nodes[ctn].left_px - sign * dl;
        hi = from.nodes[ctn].right_px - sign * dr;
      }
      ++*candidates;
      // Disparities 0..max_d at the left end: the right view's left end lies in
      // [left - max_d, left] (sign +1) or [left, left + max_d] (sign -1).
      const int first = sign > 0 ? node.left_px - max_d : node.left_px;
      const int last = sign > 0 ? node.left_px : node.left_px + max_d;
      const int32_t* it = std::lower_bound(
          to_begin, to_end, first, [&](int32_t c, int x) { return to.nodes[c].left_px < x; });
      int32_t winner = -1;
      float winner_cost = 0.0f;
      for (; it != to_end && to.nodes[*it].left_px <= last; ++it) {
        const MaxTreeNode& c = to.nodes[*it];
        const int dr = sign * (node.right_px - c.right_px);
        if (dr < 0 || dr > max_d) continue;
        if (c.left_px < lo || c.left_px > hi || c.right_px < lo || c.right_px > hi) continue;
        const float cost =
            sign > 0 ? pairCost(options, from, to, n, *it) : pairCost(options, to, from, *it, n);
        if (winner < 0 || cost < winner_cost) {
          winner = *it;
          winner_cost = cost;
        }
      }
      (*best)[n] = winner;
      (*best_cost)[n] = winner_cost;
    }
  }
}

Status MaxTreeMatcher::compute(const ImageU8& left,
                               const ImageU8& right,
                               const MaxTreeOptions& options,
                               MaxTreeResult* result) {
  if (result == nullptr) return Status::error("MaxTreeMatcher::compute: result is null");
  if (left.empty() || right.empty()) return Status::error("MaxTreeMatcher::compute: empty image");
  if (left.width != right.width || left.height != right.height) {
    return Status::error("MaxTreeMatcher::compute: left (" + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ") and right (" +
                         std::to_string(right.width) + "x" + std::to_string(right.height) +
                         ") images differ in size");
  }
  if (Status s = options.validate(); !s) return s;
  if (options.max_disparity_px >= left.width) {
    return Status::error(
        "MaxTreeOptions: max_disparity_px = " + std::to_string(options.max_disparity_px) +
        "; must be below the image width " + std::to_string(left.width));
  }
  computed_ = false;
  width_ = left.width;
  height_ = left.height;
  neighbourhood_ = options.neighbourhood_nodes;
  const int w = width_;
  const int h = height_;
  const int max_width = options.max_node_width_px > 0 ? options.max_node_width_px : w / 3;
  buildView(left, options, max_width, &left_);
  buildView(right, options, max_width, &right_);

  std::vector<MaxTreeLevelStats> stats;
  for (size_t li = 0; li < options.levels.size(); ++li) {
    const int level = options.levels[li];
    prepareLevel(level, max_width, neighbourhood_, &left_);
    prepareLevel(level, max_width, neighbourhood_, &right_);
    MaxTreeLevelStats st;
    st.level = level;
    int64_t right_candidates = 0;
    matchLevel(static_cast<int>(li),
               options,
               +1,
               left_,
               right_,
               &left_.best,
               &left_.best_cost,
               &st.candidates);
    matchLevel(static_cast<int>(li),
               options,
               -1,
               right_,
               left_,
               &right_.best,
               &right_.best_cost,
               &right_candidates);
    // Eq. 6: keep the pairs that are each other's winner.
    for (int32_t si : left_.sorted) {
      const int32_t r = left_.best[si];
      if (r < 0 || right_.best[r] != si) continue;
      const auto dl = static_cast<int16_t>(left_.nodes[si].left_px - right_.nodes[r].left_px);
      const auto dr = static_cast<int16_t>(left_.nodes[si].right_px - right_.nodes[r].right_px);
      left_.matched[si] = right_.matched[r] = 1;
      left_.d_left[si] = right_.d_left[r] = dl;
      left_.d_right[si] = right_.d_right[r] = dr;
      ++st.matched;
    }
    stats.push_back(st);
  }

  // §2.5: the last level's matched nodes take their neighbourhood's median disparities.
  MaxTreeResult out;
  out.semi_dense = ImageF32(w, h, kNoDisparity);
  ImageF32 raw(w, h, kNoDisparity);
  ImageF32 raw_cost(w, h, 0.0f);
  for (int32_t n : left_.sorted) {
    if (left_.matched[n] == 0) continue;
    const MaxTreeNode& node = left_.nodes[n];
    const int v = left_.node_row[n];
    int dl = 0;
    int dr = 0;
    medianDisparity(left_, n, neighbourhood_, &dl, &dr);
    const auto fill = static_cast<float>(std::min(dl, dr));
    float* row = out.semi_dense.row(v);
    for (int x = node.left_px; x <= node.right_px; ++x) row[x] = fill;
    raw(node.left_px, v) = static_cast<float>(dl);
    raw(node.right_px, v) = static_cast<float>(dr);
    raw_cost(node.left_px, v) = raw_cost(node.right_px, v) = left_.best_cost[n];
  }
  // Sparse outlier filter: keep a point when at least as many valid points in the window are
  // similar (within similarity_px, itself included) as are not. The points are sparse (~2 %),
  // so the window is searched in per-row lists of the valid columns rather than pixel by pixel.
  out.sparse = raw;
  if (options.outlier_filter) {
    const int half = options.outlier_window_px / 2;
    const auto tol = static_cast<float>(options.similarity_px);
    std::vector<int32_t> cols;
    std::vector<int32_t> col_first(static_cast<size_t>(h) + 1, 0);
    for (int v = 0; v < h; ++v) {
      col_first[v] = static_cast<int32_t>(cols.size());
      const float* row = raw.row(v);
      for (int u = 0; u < w; ++u) {
        if (row[u] >= 0.0f) cols.push_back(u);
      }
    }
    col_first[h] = static_cast<int32_t>(cols.size());
    for (int v = 0; v < h; ++v) {
      for (int32_t i = col_first[v]; i < col_first[v + 1]; ++i) {
        const int u = cols[i];
        const float d = raw(u, v);
        int similar = 0;
        int other = 0;
        for (int r = std::max(0, v - half); r <= std::min(h - 1, v + half); ++r) {
          const float* row = raw.row(r);
          const int32_t* end = cols.data() + col_first[r + 1];
          for (const int32_t* c = std::lower_bound(
                   static_cast<const int32_t*>(cols.data() + col_first[r]), end, u - half);
               c != end && *c <= u + half;
               ++c) {
            if (std::fabs(row[*c] - d) <= tol) {
              ++similar;
            } else {
              ++other;
            }
          }
        }
        if (similar < other) out.sparse(u, v) = kNoDisparity;
      }
    }
  }
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      if (out.sparse(u, v) >= 0.0f)
        out.points.push_back(MaxTreePoint{u, v, out.sparse(u, v), raw_cost(u, v)});
    }
  }
  out.levels = std::move(stats);
  *result = std::move(out);
  computed_ = true;
  return Status::ok();
}

Status MaxTreeMatcher::hypothesesAt(const std::vector<Corner>& corners,
                                    const MaxTreeOptions& options,
                                    StereoHypotheses* out) const {
  if (out == nullptr) return Status::error("MaxTreeMatcher::hypothesesAt: out is null");
  if (!computed_) return Status::error("MaxTreeMatcher::hypothesesAt: no successful compute()");
  if (Status s = options.validate(); !s) return s;
  out->clear();
  struct Candidate {
    int d = 0;
    float cost = 0.0f;
    bool lr = false;
  };
  std::vector<int32_t> seen;
  std::vector<Candidate> cands;
  const int r = options.corner_radius_px;
  for (const Corner& corner : corners) {
    const int u = corner.u_px;
    const int v = corner.v_px;
    if (u < 0 || u >= width_ || v < 0 || v >= height_) continue;
    seen.clear();
    cands.clear();
    for (int x = std::max(0, u - r); x <= std::min(width_ - 1, u + r); ++x) {
      for (int32_t a = left_.pixel_node[static_cast<size_t>(v) * width_ + x]; a >= 0;
           a = left_.nodes[a].parent) {
        const int32_t b = left_.best[a];
        if (b < 0 || std::find(seen.begin(), seen.end(), a) != seen.end()) continue;
        seen.push_back(a);
        const MaxTreeNode& na = left_.nodes[a];
        const MaxTreeNode& nb = right_.nodes[b];
        const bool nearer_left = u - na.left_px <= na.right_px - u;
        Candidate c;
        c.d = nearer_left ? na.left_px - nb.left_px : na.right_px - nb.right_px;
        c.cost = left_.best_cost[a];
        c.lr = left_.matched[a] != 0;
        cands.push_back(c);
      }
    }
    std::sort(cands.begin(), cands.end(), [](const Candidate& p, const Candidate& q) {
      return p.cost < q.cost || (p.cost == q.cost && (p.lr > q.lr || (p.lr == q.lr && p.d < q.d)));
    });
    SalientPoint point;
    point.corner = corner;
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());
    point.complete = false;
    const auto point_index = static_cast<uint32_t>(out->points.size());
    const float limit = options.cost_ratio * (cands.empty() ? 0.0f : std::max(cands[0].cost, 1.0f));
    for (const Candidate& c : cands) {
      if (static_cast<int>(point.num_hypotheses) >= options.max_hypotheses) break;
      if (c.cost > limit) break;
      bool duplicate = false;
      for (uint32_t i = 0; i < point.num_hypotheses; ++i) {
        if (std::lround(out->hypotheses[point.first_hypothesis + i].d_px) == c.d) duplicate = true;
      }
      if (duplicate) continue;
      DisparityHypothesis hyp;
      hyp.d_px = static_cast<float>(c.d);
      hyp.cost = c.cost;
      hyp.point_index = point_index;
      hyp.rank = static_cast<uint8_t>(point.num_hypotheses);
      hyp.lr_consistent = c.lr;
      out->hypotheses.push_back(hyp);
      ++point.num_hypotheses;
    }
    out->points.push_back(point);
  }
  return Status::ok();
}

void sparseHypotheses(const MaxTreeResult& result, StereoHypotheses* out) {
  out->clear();
  out->points.reserve(result.points.size());
  out->hypotheses.reserve(result.points.size());
  for (const MaxTreePoint& p : result.points) {
    SalientPoint point;
    point.corner = Corner{p.u_px, p.v_px, 0.0f};
    point.first_hypothesis = static_cast<uint32_t>(out->hypotheses.size());
    point.num_hypotheses = 1;
    DisparityHypothesis hyp;
    hyp.d_px = p.d_px;
    hyp.cost = p.cost;
    hyp.point_index = static_cast<uint32_t>(out->points.size());
    hyp.lr_consistent = true;
    out->hypotheses.push_back(hyp);
    out->points.push_back(point);
  }
}

Status matchMaxTreeSalient(const ImageU8& left,
                           const ImageU8& right,
                           const std::vector<Corner>& corners,
                           const MaxTreeOptions& options,
                           StereoHypotheses* out) {
  if (out == nullptr) return Status::error("matchMaxTreeSalient: out is null");
  MaxTreeMatcher matcher;
  MaxTreeResult result;
  if (Status s = matcher.compute(left, right, options, &result); !s) return s;
  return matcher.hypothesesAt(corners, options, out);
}

}  // namespace twocam::frontend
