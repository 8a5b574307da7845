#pragma once
/// Stereo matching with 1-D Max-Trees (Brandt, Strisciuglio, Petkov and Wilkinson, "Efficient
/// binocular stereo correspondence matching with 1-D Max-Trees", Pattern Recognition Letters
/// 135, 2020; docs/matchers/maxtree.md). Instead of matching pixels, the method matches image
/// regions bounded by edges, coarse to fine, one scanline at a time:
///
///  1. Both images are median filtered (5x5, I), their Sobel responses Sx, Sy computed, and
///     the inverted, stretched, quantised gradient image G (paper Eq. 1) formed: uniform
///     regions are bright, edges dark.
///  2. Every row of G gets a 1-D Max-Tree (buildRowMaxTree, linear time): a node is a maximal
///     run of pixels whose G is >= its level, so leaves are the uniform regions and their
///     ancestors coarser regions bounded by stronger edges.
///  3. Top nodes (markTopNodes): level-0 ("fine") top nodes are leaves wider than
///     min_node_width_px and narrower than max_node_width_px; level-i ("coarse") top nodes are
///     the parents of level-(i-1) top nodes that have no level-i top node below them.
///  4. For each level of `levels`, coarsest first, left and right top nodes of that level on
///     the same row are matched winner-takes-all on the aggregated cost (Eq. 4): the mean over
///     the vertical neighbourhood (the chain of same-level top nodes crossing the node's centre
///     in the rows above, and below, up to neighbourhood_nodes each) of
///     gradient_weight * C_grad + (1 - gradient_weight) * C_context, where C_grad (Eq. 2) is the
///     L1 distance of the Sobel vectors at the two end points and C_context (Eq. 3) compares the
///     widths of the nodes' ancestor chains. The first level searches every disparity in
///     [0, max_disparity_px] (both end points); later levels only inside the region the matched
///     coarse ancestor maps to (Eq. 5). A pair is kept when each is the other's winner (left-right
///     check, Eq. 6).
///  5. Output (§2.5): each matched node of the last level takes the median left- and right-end
///     disparities of its matched neighbourhood. Semi-dense: the smaller of the two fills the
///     node's pixels. Sparse: the left median at the left end point, the right median at the
///     right end point, then the outlier filter drops points with fewer similar (within
///     similarity_px) than dissimilar valid points in an outlier_window_px square.
///
/// Disparity d = u_left - u_right >= 0 in whole pixels; maps are ImageF32 with kNoDisparity
/// (frontend/dense_sad.h) where no estimate exists. The matching itself is our code; no OpenCV.

#include <cstddef>  // before common/image.h, which uses size_t without including it
#include <cstdint>
#include <vector>

#include "common/features.h"
#include "common/image.h"
#include "common/status.h"

namespace twocam::frontend {

struct MaxTreeOptions {
  /// Largest disparity searched [px], >= 1, below the image width. The paper gives none (its
  /// first level searches "the full range"); bounding both end points' disparities by the
  /// data set's range is our addition, stereo-eval passes --max-disp.
  int max_disparity_px = 63;
  /// q of Eq. 1, in [1, 256]: G keeps 256 / q-wide grey bands. 5 as the paper (§3.1); fewer
  /// bands make coarse top nodes of successive levels differ more.
  int quantization_levels = 5;
  /// S of Algorithm 1: top-node levels matched, strictly decreasing, each in [0, 8]. {1, 0}
  /// as the paper: level-1 coarse top nodes over the full range, then the fine top nodes.
  std::vector<int> levels = {1, 0};
  /// theta_gamma [nodes], in [0, 64]: at most this many same-level neighbours above and as many
  /// below enter the aggregated cost and the medians. 6 as the paper.
  int neighbourhood_nodes = 6;
  /// alpha of Eq. 4, in [0, 1]: weight of the gradient cost against the context cost. 0.8 as
  /// the paper.
  float gradient_weight = 0.8f;
  /// theta_alpha [px], >= 0: fine top nodes must be wider than this. 3 as the paper.
  int min_node_width_px = 3;
  /// theta_beta [px], >= 0: matched nodes must be narrower than this; 0 = a third of the image
  /// width, the paper's setting for Middlebury and KITTI.
  int max_node_width_px = 0;
  /// Sobel kernel size for Eq. 1 and Eq. 2 [px], 3 or 5. The paper's text says 5x5; the
  /// authors' released code (MaxTreeS 1.0, which produced its tables) calls OpenCV's Sobel with
  /// the default 3x3 kernel. 5x5 responds 16x more strongly to a ramp, so Eq. 1's fixed
  /// stretch then marks most textured pixels as edge: measured on Tsukuba semi-dense density
  /// 2.2 % (5x5) against the paper's tens of percent. 3 by default.
  int sobel_size_px = 3;
  /// theta_omega [px], >= 0: sparse outlier filter, points within this of the centre's
  /// disparity count as similar. 3 as the paper.
  int similarity_px = 3;
  /// Side of the outlier filter's square window [px], odd, >= 3. The paper's
  /// "x - 21 <= c < x + 21" (and its code, radius 21) made symmetric: 43.
  int outlier_window_px = 43;
  /// Run the sparse outlier filter (§2.5). true as the paper.
  bool outlier_filter = true;

  // Salient API (matchMaxTreeSalient) only.
  /// A matched node is a hypothesis for a corner when the corner lies within this distance of
  /// the node's interval [px], >= 0. Harris corners sit on edges, which belong to no top node;
  /// 2 px is the half width of the 5x5 Sobel / median support that separates a node's end
  /// point from the edge it stops at.
  int corner_radius_px = 2;
  /// Largest number of hypotheses per corner, in [1, 255]. 4 as frontend::matchSalient.
  int max_hypotheses = 4;
  /// A hypothesis is kept when its cost <= cost_ratio * best cost (>= 1). 3 as matchSalient.
  float cost_ratio = 3.0f;

  /// OK, or an error naming the first broken constraint and its value.
  [[nodiscard]] Status validate() const;
};

/// One node of a row's Max-Tree. The component is the pixel interval [left_px, right_px];
/// the node's own pixels are those in it whose G equals `level`, the rest belong to descendants.
struct MaxTreeNode {
  int32_t left_px = 0;
  int32_t right_px = 0;
  /// Index of the parent in the same row's node array; -1 for the root.
  int32_t parent = -1;
  /// Number of ancestors (0 for the root), #a of Eq. 3.
  int32_t depth = 0;
  int32_t num_children = 0;
  /// Grey level of G the component is cut at.
  uint8_t level = 0;
  /// Top-node level i (phi_i) of the node, -1 when it is none (markTopNodes).
  int8_t top_level = -1;

  [[nodiscard]] int width() const { return right_px - left_px + 1; }
};

/// Builds the Max-Tree of one row g[0..width) in O(width) (a stack of open components, the
/// 1-D case of Wilkinson's algorithm). nodes is cleared and filled; pixel_node[x] receives the
/// index of the node owning pixel x (the node at level g[x] containing x). Nodes are in
/// creation order, the root is the node with parent -1. width must be > 0.
void buildRowMaxTree(const uint8_t* g,
                     int width,
                     std::vector<MaxTreeNode>* nodes,
                     int32_t* pixel_node);

/// Sets every node's top_level for levels 0..max_level (see the file comment, step 3), -1
/// elsewhere. A level-0 top node is a leaf with min_width_px < width < max_width_px.
void markTopNodes(int min_width_px,
                  int max_width_px,
                  int max_level,
                  std::vector<MaxTreeNode>* nodes);

/// G of Eq. 1 from a median-filtered image: 255 - (|Sx| + |Sy|) / 2 (Sobel of sobel_size_px,
/// 3 or 5, unnormalised), stretched linearly from [127, 255] to [0, 255] (clamped), then cut to
/// multiples of 256 / q. sx, sy receive the Sobel responses (replicated border; Sy positive
/// downwards). Fails on an empty image, bad q or bad size.
Status invertedGradientImage(const ImageU8& smoothed,
                             int quantization_levels,
                             int sobel_size_px,
                             ImageU8* g,
                             Image<int16_t>* sx,
                             Image<int16_t>* sy);

/// 5x5 median filter with replicated border (step 1).
void medianFilter5x5(const ImageU8& image, ImageU8* out);

/// One sparse output point: a matched node end point that survived the outlier filter.
struct MaxTreePoint {
  int u_px = 0;
  int v_px = 0;
  /// Disparity [px], the neighbourhood median of that end point's disparities.
  float d_px = 0.0f;
  /// Aggregated cost (Eq. 4) of the node pair it comes from [grey levels].
  float cost = 0.0f;
};

/// Counts of one run, per entry of MaxTreeOptions::levels.
struct MaxTreeLevelStats {
  int level = 0;
  /// Left top nodes of this level that were allowed to search (width, border, ancestor).
  int64_t candidates = 0;
  /// Pairs that passed the left-right check.
  int64_t matched = 0;
};

struct MaxTreeResult {
  /// Semi-dense left-view map [px]: each matched fine node filled with one value.
  ImageF32 semi_dense;
  /// Sparse left-view map [px]: the points below, kNoDisparity elsewhere.
  ImageF32 sparse;
  /// The sparse points in row-major order.
  std::vector<MaxTreePoint> points;
  std::vector<MaxTreeLevelStats> levels;
};

/// The matcher; keeps trees and scratch buffers between calls (not thread-safe). Results are a
/// pure function of the inputs.
class MaxTreeMatcher {
 public:
  /// Runs steps 1-5 on a rectified pair. Errors (result untouched): null result, empty images
  /// or images of different sizes, invalid options, max_disparity_px >= width.
  Status compute(const ImageU8& left,
                 const ImageU8& right,
                 const MaxTreeOptions& options,
                 MaxTreeResult* result);

  /// Salient API (same contract as frontend::matchSalient): after compute() on the same pair,
  /// one SalientPoint per corner inside the image, in input order. Its hypotheses are the
  /// left-to-right winners of the matched-level left nodes whose interval, widened by
  /// corner_radius_px, covers the corner (all levels of `levels`); d_px is that pair's
  /// disparity at the node end nearer the corner, cost its aggregated cost, lr_consistent
  /// whether the pair passed the left-right check. Distinct disparities (1 px apart, the
  /// cheaper kept), ranked by cost, within cost_ratio of the best, at most max_hypotheses.
  /// complete is false (the method cannot say what it missed). Errors (out untouched): null
  /// out, no successful compute() yet.
  Status hypothesesAt(const std::vector<Corner>& corners,
                      const MaxTreeOptions& options,
                      StereoHypotheses* out) const;

 private:
  struct View {
    ImageU8 smoothed;
    ImageU8 g;
    Image<int16_t> sx;
    Image<int16_t> sy;
    std::vector<MaxTreeNode> nodes;  // all rows, row r at [row_first[r], row_first[r + 1])
    std::vector<int32_t> row_first;
    std::vector<int32_t> pixel_node;  // global node index per pixel
    std::vector<int32_t> node_row;
    // Matching state per node (global index).
    std::vector<int32_t> best;  // winner in the other view, -1 none
    std::vector<float> best_cost;
    std::vector<uint8_t> matched;  // passed the left-right check
    std::vector<int16_t> d_left;   // end-point disparities of the matched pair [px]
    std::vector<int16_t> d_right;
    std::vector<int32_t> sorted;  // per row: matchable nodes of the current level by left end
    std::vector<int32_t> sorted_first;
    std::vector<int32_t> up;  // neighbourhood chains, neighbourhood_nodes per node
    std::vector<int32_t> down;
  };
  void buildView(const ImageU8& image, const MaxTreeOptions& options, int max_width, View* view);
  void prepareLevel(int level, int max_width, int k, View* view) const;
  void matchLevel(int level_index,
                  const MaxTreeOptions& options,
                  int sign,
                  const View& from,
                  const View& to,
                  std::vector<int32_t>* best,
                  std::vector<float>* best_cost,
                  int64_t* candidates) const;
  [[nodiscard]] float pairCost(
      const MaxTreeOptions& options, const View& lv, const View& rv, int32_t nl, int32_t nr) const;
  void medianDisparity(const View& view, int32_t node, int k, int* dl, int* dr) const;

  View left_;
  View right_;
  bool computed_ = false;
  int width_ = 0;
  int height_ = 0;
  int neighbourhood_ = 0;
};

/// The sparse points as a hypothesis source, for where Harris corners find no node (corners
/// lie on texture, nodes on the uniform regions between edges; docs/matchers/maxtree.md): one
/// SalientPoint per point in result.points order (corner = the end point, response 0,
/// complete false), one hypothesis each (d_px, cost, rank 0, lr_consistent true: every point
/// passed the left-right check). out is cleared first; out->t_ns is untouched.
void sparseHypotheses(const MaxTreeResult& result, StereoHypotheses* out);

/// Salient API: runs MaxTreeMatcher::compute() on the pair, then hypothesesAt(corners).
/// Same contract and errors as frontend::matchSalient (out cleared first, untouched on error).
Status matchMaxTreeSalient(const ImageU8& left,
                           const ImageU8& right,
                           const std::vector<Corner>& corners,
                           const MaxTreeOptions& options,
                           StereoHypotheses* out);

}  // namespace twocam::frontend
