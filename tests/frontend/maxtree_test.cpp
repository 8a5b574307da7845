#include "frontend/maxtree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "frontend/cv_interop.h"
#include "frontend/dense_sad.h"
#include "support/test_paths.h"

namespace twocam::frontend {
namespace {

// Tolerances and targets, each with its reason.
/// A disparity is bad beyond 1 px of the truth (METRICS.md bad1).
constexpr float kBad1ThresholdPx = 1.0f;
/// Piecewise-constant mosaic at a constant disparity, no noise: every node end point sits on
/// the same texture edge in both views, so practically every output is exact (measured 100 %).
constexpr double kMinMosaicCorrectPct = 98.0;
/// The mosaic's rows carry dozens of patches; the sparse output keeps at least this many points
/// (measured 3270 on 320x240).
constexpr size_t kMinMosaicPoints = 1000;
/// Fronto-parallel step: points within 1 px of the layer they lie on (measured 98.7 %); the
/// rest sit at the box edges, where a node end point may belong to either layer.
constexpr double kMinStepCorrectPct = 95.0;
/// Share of sparse points on left pixels the right camera cannot see (the occluded band left of
/// the box); the left-right check and the outlier filter remove most (measured 24 points, 1 %).
constexpr double kMaxOccludedPointPct = 2.0;
/// Tsukuba, sparse, paper defaults: measured avgerr 0.54 px at 2.1 % density (the paper:
/// Middlebury 2014 avgerr 3.17 px at 2 %, larger images and disparities).
constexpr double kMaxTsukubaSparseAvgErrPx = 0.8;
constexpr double kMinTsukubaSparseDensityPct = 1.0;
/// Salient: share of corners near node ends whose best hypothesis is within 1 px (measured
/// 100 % on the mosaic).
constexpr double kMinSalientCorrectPct = 95.0;

// ---------------------------------------------------------------------------------------------
// Hand-made rows.

TEST(MaxTreeBuild, HandMadeRowHasTheKnownNodes) {
  // Components: level 0 over all; level 5 at [1, 2]; level 3 at [4, 7]; level 7 at [5, 6].
  const std::vector<uint8_t> g = {0, 5, 5, 0, 3, 7, 7, 3, 0};
  std::vector<MaxTreeNode> nodes;
  std::vector<int32_t> pixel(g.size());
  buildRowMaxTree(g.data(), static_cast<int>(g.size()), &nodes, pixel.data());
  ASSERT_EQ(nodes.size(), 4u);
  auto find = [&](int level, int left, int right) {
    for (size_t i = 0; i < nodes.size(); ++i) {
      if (nodes[i].level == level && nodes[i].left_px == left && nodes[i].right_px == right)
        return static_cast<int32_t>(i);
    }
    return int32_t{-1};
  };
  const int32_t root = find(0, 0, 8);
  const int32_t a = find(5, 1, 2);
  const int32_t b = find(3, 4, 7);
  const int32_t c = find(7, 5, 6);
  ASSERT_GE(root, 0);
  ASSERT_GE(a, 0);
  ASSERT_GE(b, 0);
  ASSERT_GE(c, 0);
  EXPECT_EQ(nodes[root].parent, -1);
  EXPECT_EQ(nodes[a].parent, root);
  EXPECT_EQ(nodes[b].parent, root);
  EXPECT_EQ(nodes[c].parent, b);
  EXPECT_EQ(nodes[root].depth, 0);
  EXPECT_EQ(nodes[c].depth, 2);
  EXPECT_EQ(nodes[root].num_children, 2);
  EXPECT_EQ(nodes[b].num_children, 1);
  EXPECT_EQ(nodes[c].num_children, 0);
  const std::vector<int32_t> owner = {root, a, a, root, b, c, c, b, root};
  EXPECT_EQ(pixel, owner);
}

TEST(MaxTreeBuild, RowStartingHighOpensTheLowerComponentAtTheRowStart) {
  const std::vector<uint8_t> g = {9, 9, 4, 4, 9};
  std::vector<MaxTreeNode> nodes;
  std::vector<int32_t> pixel(g.size());
  buildRowMaxTree(g.data(), static_cast<int>(g.size()), &nodes, pixel.data());
  ASSERT_EQ(nodes.size(), 3u);
  const MaxTreeNode& root = nodes[pixel[2]];
  EXPECT_EQ(root.level, 4);
  EXPECT_EQ(root.left_px, 0);
  EXPECT_EQ(root.right_px, 4);
  EXPECT_EQ(root.parent, -1);
  EXPECT_EQ(nodes[pixel[0]].right_px, 1);
  EXPECT_EQ(nodes[pixel[0]].parent, pixel[2]);
  EXPECT_EQ(nodes[pixel[4]].left_px, 4);
  EXPECT_EQ(nodes[pixel[4]].parent, pixel[2]);
}

TEST(MaxTreeBuild, ConstantRowIsOneRootLeaf) {
  const std::vector<uint8_t> g(17, 200);
  std::vector<MaxTreeNode> nodes;
  std::vector<int32_t> pixel(g.size());
  buildRowMaxTree(g.data(), static_cast<int>(g.size()), &nodes, pixel.data());
  ASSERT_EQ(nodes.size(), 1u);
  EXPECT_EQ(nodes[0].width(), 17);
  EXPECT_EQ(nodes[0].num_children, 0);
}

TEST(MaxTreeBuild, RandomRowsSatisfyTheTreeInvariants) {
  std::mt19937 rng(20261203);
  std::uniform_int_distribution<int> level(0, 5);
  for (int trial = 0; trial < 1000; ++trial) {
    std::vector<uint8_t> g(1 + trial % 64);
    for (uint8_t& x : g) x = static_cast<uint8_t>(level(rng) * 51);
    std::vector<MaxTreeNode> nodes;
    std::vector<int32_t> pixel(g.size());
    buildRowMaxTree(g.data(), static_cast<int>(g.size()), &nodes, pixel.data());
    int roots = 0;
    for (const MaxTreeNode& n : nodes) {
      if (n.parent < 0) {
        ++roots;
        continue;
      }
      const MaxTreeNode& p = nodes[n.parent];
      ASSERT_LT(p.level, n.level);
      ASSERT_LE(p.left_px, n.left_px);
      ASSERT_GE(p.right_px, n.right_px);
      ASSERT_EQ(n.depth, p.depth + 1);
    }
    ASSERT_EQ(roots, 1);
    for (size_t x = 0; x < g.size(); ++x) {
      const MaxTreeNode& n = nodes[pixel[x]];
      ASSERT_EQ(n.level, g[x]);
      ASSERT_LE(n.left_px, static_cast<int>(x));
      ASSERT_GE(n.right_px, static_cast<int>(x));
      // The component is maximal: its neighbours outside are below its level.
      for (int i = n.left_px; i <= n.right_px; ++i) ASSERT_GE(g[i], n.level);
      if (n.left_px > 0) {
        ASSERT_LT(g[n.left_px - 1], n.level);
      }
      if (n.right_px + 1 < static_cast<int>(g.size())) {
        ASSERT_LT(g[n.right_px + 1], n.level);
      }
    }
  }
}

TEST(MaxTreeTopNodes, FineAndCoarseLevelsOnAHandMadeRow) {
  // root 0 [0,15]; P level 2 [1,11] with leaves [2,5] and [7,10]; a narrow leaf [13,14].
  const std::vector<uint8_t> g = {0, 2, 4, 4, 4, 4, 2, 4, 4, 4, 4, 2, 0, 4, 4, 0};
  std::vector<MaxTreeNode> nodes;
  std::vector<int32_t> pixel(g.size());
  buildRowMaxTree(g.data(), static_cast<int>(g.size()), &nodes, pixel.data());
  markTopNodes(3, 10, 2, &nodes);
  EXPECT_EQ(nodes[pixel[2]].top_level, 0);
  EXPECT_EQ(nodes[pixel[7]].top_level, 0);
  EXPECT_EQ(nodes[pixel[13]].top_level, -1);  // width 2, not > 3
  EXPECT_EQ(nodes[pixel[1]].top_level, 1);    // P, parent of both fine top nodes
  EXPECT_EQ(nodes[pixel[0]].top_level, 2);    // root, parent of P
  markTopNodes(3, 4, 2, &nodes);              // width 4 is not < 4: no fine top node at all
  for (const MaxTreeNode& n : nodes) EXPECT_EQ(n.top_level, -1);
}

TEST(MaxTreeTopNodes, ParentWithATopNodeBelowIsNotACoarseTopNode) {
  // root 0 [0,13] has a fine leaf [1,4] and P level 2 [6,12] with a fine leaf [8,11]: both the
  // root and P are parents of fine top nodes, but the root has P below it.
  const std::vector<uint8_t> g = {0, 4, 4, 4, 4, 0, 2, 2, 4, 4, 4, 4, 2, 0};
  std::vector<MaxTreeNode> nodes;
  std::vector<int32_t> pixel(g.size());
  buildRowMaxTree(g.data(), static_cast<int>(g.size()), &nodes, pixel.data());
  markTopNodes(3, 100, 1, &nodes);
  EXPECT_EQ(nodes[pixel[1]].top_level, 0);
  EXPECT_EQ(nodes[pixel[8]].top_level, 0);
  EXPECT_EQ(nodes[pixel[6]].top_level, 1);
  EXPECT_EQ(nodes[pixel[0]].top_level, -1);
}

TEST(MaxTreeGradient, FlatImageIsUniformAndAStepIsAnEdge) {
  ImageU8 flat(20, 10, 90);
  ImageU8 g;
  Image<int16_t> sx, sy;
  ASSERT_TRUE(invertedGradientImage(flat, 5, 3, &g, &sx, &sy).isOk());
  for (uint8_t x : g.data) EXPECT_EQ(x, 255);
  for (int16_t x : sx.data) EXPECT_EQ(x, 0);
  ImageU8 step(20, 10, 20);
  for (int v = 0; v < 10; ++v)
    for (int u = 10; u < 20; ++u) step(u, v) = 220;
  ASSERT_TRUE(invertedGradientImage(step, 5, 3, &g, &sx, &sy).isOk());
  EXPECT_EQ(g(9, 5), 0);
  EXPECT_EQ(g(10, 5), 0);
  EXPECT_EQ(g(3, 5), 255);
  EXPECT_EQ(sx(9, 5), 4 * 200);  // 3x3 Sobel gain 4 on a 200-level step
  EXPECT_EQ(sy(9, 5), 0);
  EXPECT_FALSE(invertedGradientImage(step, 0, 3, &g, &sx, &sy).isOk());
  EXPECT_FALSE(invertedGradientImage(step, 5, 4, &g, &sx, &sy).isOk());
  EXPECT_FALSE(invertedGradientImage(ImageU8(), 5, 3, &g, &sx, &sy).isOk());
}

TEST(MaxTreeMedian, RemovesAnIsolatedSpike) {
  ImageU8 im(9, 9, 50);
  im(4, 4) = 250;
  ImageU8 out;
  medianFilter5x5(im, &out);
  for (uint8_t x : out.data) EXPECT_EQ(x, 50);
}

TEST(MaxTreeMedian, EqualsOpenCvMedianBlurWithReplicatedBorder) {
  std::mt19937 rng(20261204);
  std::uniform_int_distribution<int> grey(0, 255);
  for (int trial = 0; trial < 20; ++trial) {
    const int w = 5 + 7 * trial;
    const int h = 5 + 3 * trial;
    ImageU8 im(w, h);
    for (uint8_t& x : im.data) x = static_cast<uint8_t>(grey(rng));
    ImageU8 ours;
    medianFilter5x5(im, &ours);
    cv::Mat padded;
    cv::Mat reference;
    cv::copyMakeBorder(asMat(im), padded, 2, 2, 2, 2, cv::BORDER_REPLICATE);
    cv::medianBlur(padded, reference, 5);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) ASSERT_EQ(ours(u, v), reference.at<uint8_t>(v + 2, u + 2));
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Synthetic pairs.

/// Piecewise-constant texture ("mosaic"): bands of 6..12 rows, each cut into patches 6..20 px
/// wide of random grey levels that differ from their neighbour by at least 60, so every patch is
/// a uniform region bounded by strong edges: what the method matches.
ImageU8 mosaic(int width, int height, std::mt19937& rng) {
  ImageU8 t(width, height);
  std::uniform_int_distribution<int> band(6, 12);
  std::uniform_int_distribution<int> patch(6, 20);
  std::uniform_int_distribution<int> grey(0, 255);
  for (int v0 = 0; v0 < height;) {
    const int v1 = std::min(height, v0 + band(rng));
    int prev = -1000;
    for (int u0 = 0; u0 < width;) {
      const int u1 = std::min(width, u0 + patch(rng));
      int value = grey(rng);
      while (std::abs(value - prev) < 60) value = grey(rng);
      prev = value;
      for (int v = v0; v < v1; ++v)
        for (int u = u0; u < u1; ++u) t(u, v) = static_cast<uint8_t>(value);
      u0 = u1;
    }
    v0 = v1;
  }
  return t;
}

struct Pair {
  ImageU8 left;
  ImageU8 right;
  ImageF32 truth;
  ImageU8 visible;  // 255 where the right camera sees the left pixel
};

/// Background mosaic at bg_d; with box_d > 0 a box of another mosaic over left columns
/// [box_u0, box_u1) at box_d, painted as a rectified rig sees it.
Pair makePair(int width, int height, int bg_d, int box_d, int box_u0, int box_u1, uint32_t seed) {
  std::mt19937 rng(seed);
  const ImageU8 bg = mosaic(width + bg_d, height, rng);
  const ImageU8 fg = mosaic(width + box_d, height, rng);
  Pair p;
  p.left = ImageU8(width, height);
  p.right = ImageU8(width, height);
  p.truth = ImageF32(width, height, static_cast<float>(bg_d));
  p.visible = ImageU8(width, height, 255);
  // Left u shows bg(u), right u_r shows bg(u_r + bg_d): left u and right u - bg_d see one texel.
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      p.left(u, v) = bg(u, v);
      p.right(u, v) = u + bg_d < bg.width ? bg(u + bg_d, v) : bg(bg.width - 1, v);
    }
  }
  if (box_d > 0) {
    for (int v = 0; v < height; ++v) {
      for (int u = box_u0; u < box_u1; ++u) {
        p.left(u, v) = fg(u, v);
        p.truth(u, v) = static_cast<float>(box_d);
        const int ur = u - box_d;
        if (ur >= 0) p.right(ur, v) = fg(u, v);
      }
      // Background left pixels whose right partner the box covers are occluded.
      for (int u = 0; u < width; ++u) {
        if (u >= box_u0 && u < box_u1) continue;
        const int ur = u - bg_d;
        if (ur >= box_u0 - box_d && ur < box_u1 - box_d) p.visible(u, v) = 0;
      }
    }
  }
  return p;
}

double correctPct(const std::vector<MaxTreePoint>& points, const ImageF32& truth) {
  if (points.empty()) return 0.0;
  int good = 0;
  for (const MaxTreePoint& p : points) {
    if (std::fabs(p.d_px - truth(p.u_px, p.v_px)) <= kBad1ThresholdPx) ++good;
  }
  return 100.0 * good / static_cast<double>(points.size());
}

TEST(MaxTreeMatcher, ConstantDisparityMosaicIsRecovered) {
  const Pair p = makePair(320, 240, 7, 0, 0, 0, 11);
  MaxTreeOptions o;
  o.max_disparity_px = 20;
  MaxTreeMatcher m;
  MaxTreeResult r;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &r).isOk());
  EXPECT_GE(r.points.size(), kMinMosaicPoints);
  EXPECT_GE(correctPct(r.points, p.truth), kMinMosaicCorrectPct);
  RecordProperty("points", std::to_string(r.points.size()));
  RecordProperty("correct_pct", std::to_string(correctPct(r.points, p.truth)));
  int semi = 0;
  int semi_good = 0;
  for (size_t i = 0; i < r.semi_dense.data.size(); ++i) {
    if (r.semi_dense.data[i] < 0.0f) continue;
    ++semi;
    if (std::fabs(r.semi_dense.data[i] - 7.0f) <= kBad1ThresholdPx) ++semi_good;
  }
  ASSERT_GT(semi, 0);
  EXPECT_GE(100.0 * semi_good / semi, kMinMosaicCorrectPct);
  RecordProperty("semi_correct_pct", std::to_string(100.0 * semi_good / semi));
  ASSERT_EQ(r.levels.size(), 2u);
  EXPECT_EQ(r.levels[0].level, 1);
  EXPECT_GT(r.levels[0].matched, 0);
  EXPECT_GT(r.levels[1].matched, 0);
  // Sparse map and point list agree.
  for (const MaxTreePoint& q : r.points) EXPECT_EQ(r.sparse(q.u_px, q.v_px), q.d_px);
}

TEST(MaxTreeMatcher, FrontoParallelStepKeepsBothLayersAndDropsTheOcclusion) {
  const Pair p = makePair(320, 240, 4, 16, 120, 220, 12);
  MaxTreeOptions o;
  o.max_disparity_px = 24;
  MaxTreeMatcher m;
  MaxTreeResult r;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &r).isOk());
  int box = 0;
  int occluded = 0;
  for (const MaxTreePoint& q : r.points) {
    if (p.truth(q.u_px, q.v_px) > 10.0f) ++box;
    if (p.visible(q.u_px, q.v_px) == 0) ++occluded;
  }
  EXPECT_GT(box, 100);
  EXPECT_GT(static_cast<int>(r.points.size()) - box, 100);
  EXPECT_GE(correctPct(r.points, p.truth), kMinStepCorrectPct);
  RecordProperty("step_correct_pct", std::to_string(correctPct(r.points, p.truth)));
  RecordProperty("occluded_points", std::to_string(occluded));
  RecordProperty("box_points", std::to_string(box));
  EXPECT_LE(100.0 * occluded / static_cast<double>(r.points.size()), kMaxOccludedPointPct);
}

TEST(MaxTreeMatcher, LeftRightCheckRejectsRegionsTheRightViewLacks) {
  // The right view of the middle third is replaced by a flat grey: left nodes there still find a
  // winner, but no right node picks them back, so no output falls there.
  Pair p = makePair(240, 120, 5, 0, 0, 0, 13);
  for (int v = 0; v < p.right.height; ++v)
    for (int u = 80; u < 160; ++u) p.right(u, v) = 128;
  MaxTreeOptions o;
  o.max_disparity_px = 12;
  MaxTreeMatcher m;
  MaxTreeResult r;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &r).isOk());
  ASSERT_FALSE(r.points.empty());
  for (const MaxTreePoint& q : r.points) {
    EXPECT_FALSE(q.u_px > 95 && q.u_px < 150) << "u " << q.u_px << " v " << q.v_px;
  }
}

TEST(MaxTreeMatcher, OutlierFilterOnlyRemovesPoints) {
  const Pair p = makePair(240, 160, 6, 14, 80, 160, 14);
  MaxTreeOptions o;
  o.max_disparity_px = 20;
  MaxTreeMatcher m;
  MaxTreeResult with, without;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &with).isOk());
  o.outlier_filter = false;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &without).isOk());
  EXPECT_LE(with.points.size(), without.points.size());
  for (const MaxTreePoint& q : with.points) EXPECT_EQ(without.sparse(q.u_px, q.v_px), q.d_px);
}

TEST(MaxTreeMatcher, RepeatedRunsGiveIdenticalOutput) {
  const Pair p = makePair(200, 120, 3, 9, 60, 140, 15);
  MaxTreeOptions o;
  o.max_disparity_px = 16;
  MaxTreeMatcher m;
  MaxTreeResult a, b;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &a).isOk());
  ASSERT_TRUE(MaxTreeMatcher().compute(p.left, p.right, o, &b).isOk());
  EXPECT_EQ(a.semi_dense.data, b.semi_dense.data);
  EXPECT_EQ(a.sparse.data, b.sparse.data);
}

TEST(MaxTreeMatcher, BadInputIsAnErrorAndLeavesTheResultUntouched) {
  const Pair p = makePair(64, 32, 3, 0, 0, 0, 16);
  MaxTreeOptions o;
  o.max_disparity_px = 10;
  MaxTreeMatcher m;
  MaxTreeResult r;
  r.points.push_back(MaxTreePoint{1, 2, 3.0f, 4.0f});
  EXPECT_FALSE(m.compute(ImageU8(), p.right, o, &r).isOk());
  EXPECT_FALSE(m.compute(p.left, ImageU8(63, 32), o, &r).isOk());
  EXPECT_FALSE(m.compute(p.left, p.right, o, nullptr).isOk());
  MaxTreeOptions wide = o;
  wide.max_disparity_px = 64;
  const Status s = m.compute(p.left, p.right, wide, &r);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("max_disparity_px = 64"), std::string::npos) << s.message();
  ASSERT_EQ(r.points.size(), 1u);
  StereoHypotheses h;
  EXPECT_FALSE(m.hypothesesAt({}, o, &h).isOk());  // no successful compute yet
}

TEST(MaxTreeMatcher, TinyAndOddImagesDoNotBreakIt) {
  std::mt19937 rng(20261205);
  std::uniform_int_distribution<int> grey(0, 255);
  MaxTreeMatcher m;  // reused across sizes: scratch buffers must follow
  for (int trial = 0; trial < 200; ++trial) {
    const int w = 2 + trial % 23;
    const int h = 1 + (trial / 23) % 9;
    ImageU8 left(w, h);
    ImageU8 right(w, h);
    for (uint8_t& x : left.data) x = static_cast<uint8_t>(trial % 3 == 0 ? 77 : grey(rng));
    for (uint8_t& x : right.data) x = static_cast<uint8_t>(trial % 3 == 0 ? 77 : grey(rng));
    MaxTreeOptions o;
    o.max_disparity_px = 1 + trial % (w - 1);
    o.levels = trial % 2 == 0 ? std::vector<int>{1, 0} : std::vector<int>{2, 1, 0};
    MaxTreeResult r;
    ASSERT_TRUE(m.compute(left, right, o, &r).isOk()) << w << "x" << h;
    ASSERT_EQ(r.sparse.width, w);
    ASSERT_EQ(r.semi_dense.height, h);
    for (const MaxTreePoint& q : r.points) {
      ASSERT_GE(q.d_px, 0.0f);
      ASSERT_LE(q.d_px, static_cast<float>(o.max_disparity_px));
    }
    StereoHypotheses hyps;
    ASSERT_TRUE(m.hypothesesAt({Corner{0, 0, 1.0f}, Corner{w - 1, h - 1, 1.0f}}, o, &hyps).isOk());
    ASSERT_EQ(hyps.points.size(), 2u);
  }
}

TEST(MaxTreeOptions, ValidateNamesTheBrokenField) {
  auto message = [](const MaxTreeOptions& o) { return o.validate().message(); };
  EXPECT_TRUE(MaxTreeOptions().validate().isOk());
  MaxTreeOptions o;
  o.max_disparity_px = 0;
  EXPECT_NE(message(o).find("max_disparity_px = 0"), std::string::npos);
  o = MaxTreeOptions();
  o.quantization_levels = 300;
  EXPECT_NE(message(o).find("quantization_levels = 300"), std::string::npos);
  o = MaxTreeOptions();
  o.levels = {0, 1};
  EXPECT_NE(message(o).find("levels[1] = 1"), std::string::npos);
  o.levels = {};
  EXPECT_NE(message(o).find("levels is empty"), std::string::npos);
  o = MaxTreeOptions();
  o.levels = {9, 0};
  EXPECT_NE(message(o).find("levels[0] = 9"), std::string::npos);
  o = MaxTreeOptions();
  o.gradient_weight = 1.5f;
  EXPECT_NE(message(o).find("gradient_weight"), std::string::npos);
  o = MaxTreeOptions();
  o.sobel_size_px = 7;
  EXPECT_NE(message(o).find("sobel_size_px = 7"), std::string::npos);
  o = MaxTreeOptions();
  o.outlier_window_px = 20;
  EXPECT_NE(message(o).find("outlier_window_px = 20"), std::string::npos);
  o = MaxTreeOptions();
  o.neighbourhood_nodes = -1;
  EXPECT_NE(message(o).find("neighbourhood_nodes = -1"), std::string::npos);
  o = MaxTreeOptions();
  o.cost_ratio = 0.5f;
  EXPECT_NE(message(o).find("cost_ratio"), std::string::npos);
  o = MaxTreeOptions();
  o.max_hypotheses = 0;
  EXPECT_NE(message(o).find("max_hypotheses = 0"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Salient API.

TEST(MaxTreeSalient, CornersAtPatchEdgesGetTheTrueDisparityFirst) {
  const Pair p = makePair(320, 240, 7, 0, 0, 0, 17);
  MaxTreeOptions o;
  o.max_disparity_px = 20;
  MaxTreeMatcher m;
  MaxTreeResult r;
  ASSERT_TRUE(m.compute(p.left, p.right, o, &r).isOk());
  // Corners one pixel beside the sparse points (an edge pixel, as Harris would pick), plus one
  // outside the image that must be skipped.
  std::vector<Corner> corners;
  for (size_t i = 0; i < r.points.size(); i += 7)
    corners.push_back(Corner{std::max(0, r.points[i].u_px - 1), r.points[i].v_px, 1.0f});
  const size_t inside = corners.size();
  corners.insert(corners.begin() + 1, Corner{-5, 3, 1.0f});
  StereoHypotheses h;
  h.points.resize(3);  // cleared first
  ASSERT_TRUE(m.hypothesesAt(corners, o, &h).isOk());
  ASSERT_EQ(h.points.size(), inside);
  int good = 0;
  for (size_t i = 0; i < h.points.size(); ++i) {
    const SalientPoint& sp = h.points[i];
    EXPECT_EQ(sp.corner.u_px, corners[i == 0 ? 0 : i + 1].u_px);
    ASSERT_GE(sp.num_hypotheses, 1u);
    EXPECT_LE(sp.num_hypotheses, static_cast<uint32_t>(o.max_hypotheses));
    for (uint32_t k = 0; k < sp.num_hypotheses; ++k) {
      const DisparityHypothesis& hyp = h.hypotheses[sp.first_hypothesis + k];
      EXPECT_EQ(hyp.point_index, i);
      EXPECT_EQ(hyp.rank, k);
      if (k > 0) {
        EXPECT_GE(hyp.cost, h.hypotheses[sp.first_hypothesis + k - 1].cost);
      }
    }
    if (std::fabs(h.hypotheses[sp.first_hypothesis].d_px - 7.0f) <= kBad1ThresholdPx) ++good;
  }
  EXPECT_GE(100.0 * good / static_cast<double>(h.points.size()), kMinSalientCorrectPct);
  RecordProperty("salient_correct_pct",
                 std::to_string(100.0 * good / static_cast<double>(h.points.size())));
}

TEST(MaxTreeSalient, SparsePointsBecomeOneHypothesisEach) {
  const Pair p = makePair(160, 96, 4, 0, 0, 0, 19);
  MaxTreeOptions o;
  o.max_disparity_px = 10;
  MaxTreeResult r;
  ASSERT_TRUE(MaxTreeMatcher().compute(p.left, p.right, o, &r).isOk());
  ASSERT_FALSE(r.points.empty());
  StereoHypotheses h;
  h.hypotheses.resize(5);  // cleared first
  sparseHypotheses(r, &h);
  ASSERT_EQ(h.points.size(), r.points.size());
  ASSERT_EQ(h.hypotheses.size(), r.points.size());
  for (size_t i = 0; i < r.points.size(); ++i) {
    EXPECT_EQ(h.points[i].corner.u_px, r.points[i].u_px);
    EXPECT_EQ(h.points[i].corner.v_px, r.points[i].v_px);
    EXPECT_EQ(h.points[i].first_hypothesis, i);
    EXPECT_EQ(h.points[i].num_hypotheses, 1u);
    EXPECT_EQ(h.hypotheses[i].d_px, r.points[i].d_px);
    EXPECT_EQ(h.hypotheses[i].point_index, i);
    EXPECT_TRUE(h.hypotheses[i].lr_consistent);
  }
}

TEST(MaxTreeSalient, ErrorsLeaveTheOutputUntouched) {
  const Pair p = makePair(64, 32, 3, 0, 0, 0, 18);
  MaxTreeOptions o;
  o.max_disparity_px = 10;
  StereoHypotheses h;
  h.points.resize(2);
  EXPECT_FALSE(matchMaxTreeSalient(p.left, ImageU8(), {}, o, &h).isOk());
  EXPECT_FALSE(matchMaxTreeSalient(p.left, p.right, {}, o, nullptr).isOk());
  o.max_hypotheses = 0;
  EXPECT_FALSE(matchMaxTreeSalient(p.left, p.right, {}, o, &h).isOk());
  EXPECT_EQ(h.points.size(), 2u);
}

// ---------------------------------------------------------------------------------------------
// Middlebury.

TEST(MaxTreeMiddlebury, TsukubaSparseIsAccurateAtAboutTwoPercentDensity) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  ImageU8 left, right, gt;
  ASSERT_TRUE(loadGrey(data + "/middlebury/tsukuba/im3.png", &left).isOk());
  ASSERT_TRUE(loadGrey(data + "/middlebury/tsukuba/im4.png", &right).isOk());
  ASSERT_TRUE(loadGrey(data + "/middlebury/tsukuba/disp3.pgm", &gt).isOk());
  MaxTreeOptions o;
  o.max_disparity_px = 16;
  MaxTreeResult r;
  ASSERT_TRUE(MaxTreeMatcher().compute(left, right, o, &r).isOk());
  int evaluated = 0;
  int estimated = 0;
  double err = 0.0;
  for (size_t i = 0; i < gt.data.size(); ++i) {
    if (gt.data[i] == 0) continue;  // no ground truth
    ++evaluated;
    if (r.sparse.data[i] < 0.0f) continue;
    ++estimated;
    err += std::fabs(r.sparse.data[i] - gt.data[i] / 16.0);
  }
  ASSERT_GT(estimated, 0);
  const double avgerr = err / estimated;
  const double density = 100.0 * estimated / evaluated;
  EXPECT_LE(avgerr, kMaxTsukubaSparseAvgErrPx);
  EXPECT_GE(density, kMinTsukubaSparseDensityPct);
  RecordProperty("sparse_avgerr_px", std::to_string(avgerr));
  RecordProperty("sparse_density_pct", std::to_string(density));
}

}  // namespace
}  // namespace twocam::frontend
