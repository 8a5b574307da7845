#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "frontend/support_value_internal.h"

// The support-value matcher's candidate choice, row constraints and post-processing
// (support_value_internal.h, support_value_constraints.cpp) on hand-made curves and maps.

namespace twocam::frontend::internal::support {
namespace {

/// No estimate in the int16 maps of the constraints.
constexpr int16_t kNone = kNoMatch;

TEST(SelectCandidates, LocalMaximaWithinTheMarginBestFirstPlateausOnce) {
  // Limit for margin 0.1: ceil(0.9 * 50) = 45. The plateau 1-2 counts at k = 2; k = 4 (45) is
  // at the limit; k = 5 (44) is below it and not a maximum; k = 6 is a maximum at the end.
  const std::vector<int32_t> sv = {10, 50, 50, 20, 45, 44, 49};
  int k[kMaxCandidates];
  bool dropped = true;
  ASSERT_EQ(selectCandidates(sv.data(), 1, 7, 0.1, 3, k, &dropped), 3);
  EXPECT_EQ(k[0], 2);
  EXPECT_EQ(k[1], 6);
  EXPECT_EQ(k[2], 4);
  EXPECT_FALSE(dropped);
  // Room for two: the weakest goes and the list says so.
  ASSERT_EQ(selectCandidates(sv.data(), 1, 7, 0.1, 2, k, &dropped), 2);
  EXPECT_EQ(k[0], 2);
  EXPECT_EQ(k[1], 6);
  EXPECT_TRUE(dropped);
  // A narrower margin (limit 48) keeps the two strongest without dropping anything.
  ASSERT_EQ(selectCandidates(sv.data(), 1, 7, 0.04, 2, k, &dropped), 2);
  EXPECT_FALSE(dropped);
}

TEST(SelectCandidates, StrideTiesAndEmptyCurves) {
  // Every other entry is the curve (stride 2); equal maxima keep the smaller k first.
  const std::vector<int32_t> sv = {30, -7, 10, -7, 30, -7, 10, -7};
  int k[kMaxCandidates];
  bool dropped = true;
  ASSERT_EQ(selectCandidates(sv.data(), 2, 4, 0.0, 4, k, &dropped), 2);
  EXPECT_EQ(k[0], 0);
  EXPECT_EQ(k[1], 2);
  EXPECT_FALSE(dropped);
  // No support anywhere, or no disparity to search: no candidate.
  const std::vector<int32_t> none = {0, kNoMatch, 0};
  EXPECT_EQ(selectCandidates(none.data(), 1, 3, 0.5, 4, k, &dropped), 0);
  EXPECT_EQ(selectCandidates(sv.data(), 1, 0, 0.5, 4, k, &dropped), 0);
  EXPECT_FALSE(dropped);
}

TEST(OrderRow, AConflictVoidsTheLowerScoreAndTiesKeepTheEarlierMatch) {
  // Left view (sign -1): partners x - d. x = 2 (d 1) and x = 3 (d 3) cross: partners 1 and 0.
  std::vector<int> stack;
  std::vector<int16_t> d = {kNone, kNone, 1, 3, 3, kNone};
  std::vector<float> score = {0.0f, 0.0f, 0.5f, 0.9f, 0.8f, 0.0f};
  orderRow(6, -1, d.data(), score.data(), &stack);
  // x = 3 wins over x = 2; x = 4 (partner 1) keeps the order after x = 3 (partner 0).
  EXPECT_EQ(d, (std::vector<int16_t>{kNone, kNone, kNone, 3, 3, kNone}));
  // Uniqueness: x = 2 (d 1) and x = 3 (d 2) share partner 1; with equal scores the earlier stays.
  d = {kNone, kNone, 1, 2, kNone, kNone};
  score = {0.0f, 0.0f, 0.7f, 0.7f, 0.0f, 0.0f};
  orderRow(6, -1, d.data(), score.data(), &stack);
  EXPECT_EQ(d, (std::vector<int16_t>{kNone, kNone, 1, kNone, kNone, kNone}));
  // Right view (sign +1): partners x + d; x = 0 (d 4) and x = 1 (d 2) cross at 4 and 3.
  d = {4, 2, kNone, kNone, kNone, kNone};
  score = {0.6f, 0.4f, 0.0f, 0.0f, 0.0f, 0.0f};
  orderRow(6, +1, d.data(), score.data(), &stack);
  EXPECT_EQ(d, (std::vector<int16_t>{4, kNone, kNone, kNone, kNone, kNone}));
}

TEST(ContinuityFilter, RemovesIsolatedEstimatesAndKeepsSurfaces) {
  // 5 x 5 at disparity 4 with one outlier (9) in the middle and a 5 (within 1 px) beside it.
  constexpr int kSide = 5;
  std::vector<int16_t> in(kSide * kSide, 4);
  in[2 * kSide + 2] = 9;
  in[2 * kSide + 3] = 5;
  std::vector<int16_t> out;
  continuityFilter(in, kSide, kSide, 3, 2, &out);
  std::vector<int16_t> expected = in;
  expected[2 * kSide + 2] = kNone;
  EXPECT_EQ(out, expected);
  // A corner pixel has 3 neighbours in its clipped window: asking for 4 voids every corner.
  continuityFilter(in, kSide, kSide, 3, 4, &out);
  EXPECT_EQ(out[0], kNone);
  EXPECT_EQ(out[kSide - 1], kNone);
  EXPECT_EQ(out[kSide + 1], 4);
  // min_neighbours 0 turns the constraint off.
  continuityFilter(in, kSide, kSide, 3, 0, &out);
  EXPECT_EQ(out, in);
}

TEST(ErodeDepthEdges, VoidsTheNearerSideOfAJumpOnly) {
  // One row: far (2) then near (8): the first `erosion` near pixels after the jump go.
  const std::vector<int16_t> far_near = {2, 2, 2, 2, 8, 8, 8, 8, 8, 8};
  std::vector<int16_t> out = far_near;
  erodeDepthEdges(far_near, 10, 1, 2, &out);
  EXPECT_EQ(out, (std::vector<int16_t>{2, 2, 2, 2, kNone, kNone, 8, 8, 8, 8}));
  // Near then far: the last near pixels before the jump go.
  const std::vector<int16_t> near_far = {8, 8, 8, 8, 2, 2, 2, 2, 2, 2};
  out = near_far;
  erodeDepthEdges(near_far, 10, 1, 3, &out);
  EXPECT_EQ(out, (std::vector<int16_t>{8, kNone, kNone, kNone, 2, 2, 2, 2, 2, 2}));
  // A step of 1 px is a slope, not a jump; estimates more than 3 px apart are not compared.
  const std::vector<int16_t> smooth = {2, 3, 4, kNone, kNone, kNone, kNone, 9, 9, 9};
  out = smooth;
  erodeDepthEdges(smooth, 10, 1, 2, &out);
  EXPECT_EQ(out, smooth);
  // The same jump down a column (width 1).
  out = far_near;
  erodeDepthEdges(far_near, 1, 10, 2, &out);
  EXPECT_EQ(out, (std::vector<int16_t>{2, 2, 2, 2, kNone, kNone, 8, 8, 8, 8}));
}

TEST(FillRows, LinearFartherWidthLimitAndEmptyRows) {
  ImageF32 map(6, 2, kNoDisparity);
  const float row0[6] = {kNoDisparity, 2.0f, kNoDisparity, kNoDisparity, 8.0f, kNoDisparity};
  for (int u = 0; u < 6; ++u) map(u, 0) = row0[u];
  ImageF32 linear = map;
  fillRows(SupportFill::kLinear, 0, 6, 2, &linear);
  EXPECT_FLOAT_EQ(linear(0, 0), 2.0f);  // row ends take the nearest estimate
  EXPECT_FLOAT_EQ(linear(2, 0), 4.0f);
  EXPECT_FLOAT_EQ(linear(3, 0), 6.0f);
  EXPECT_FLOAT_EQ(linear(5, 0), 8.0f);
  for (int u = 0; u < 6; ++u) EXPECT_EQ(linear(u, 1), kNoDisparity) << "a row without estimates";
  ImageF32 farther = map;
  fillRows(SupportFill::kFarther, 0, 6, 2, &farther);
  EXPECT_EQ(farther(2, 0), 2.0f);
  EXPECT_EQ(farther(3, 0), 2.0f);
  // Holes wider than max_width stay; narrower ones are filled.
  ImageF32 limited = map;
  fillRows(SupportFill::kLinear, 1, 6, 2, &limited);
  EXPECT_EQ(limited(0, 0), 2.0f);
  EXPECT_EQ(limited(2, 0), kNoDisparity);
  EXPECT_EQ(limited(3, 0), kNoDisparity);
  EXPECT_EQ(limited(5, 0), 8.0f);
  ImageF32 none = map;
  fillRows(SupportFill::kNone, 0, 6, 2, &none);
  EXPECT_EQ(none.data, map.data);
}

}  // namespace
}  // namespace twocam::frontend::internal::support
