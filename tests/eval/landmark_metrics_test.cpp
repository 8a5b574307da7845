#include "eval/landmark_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "landmarks/landmark_model.h"

namespace twocam::eval {
namespace {

TEST(LandmarkMetrics, DistinctPointsMergeWithinTheRadiusOnly) {
  constexpr double kRadiusM = 0.02;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.005f, 0.005f);  // well inside the radius
  std::vector<Eigen::Vector3f> points;
  // Ten physical points 10 cm apart, each "confirmed" 1 to 4 times with a few mm of jitter.
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3f p(0.1f * static_cast<float>(i), 1.0f, 0.5f);
    for (int k = 0; k <= i % 4; ++k)
      points.push_back(p + Eigen::Vector3f(jitter(rng), jitter(rng), jitter(rng)));
  }
  EXPECT_EQ(countDistinctPoints(points, kRadiusM), 10);
  // Across a grid-cell boundary (x = 0.02 m) the neighbour cells are searched.
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(0.0199f, 0, 0), Eigen::Vector3f(0.0201f, 0, 0)},
                                kRadiusM),
            1);
  // Just beyond the radius: two points.
  EXPECT_EQ(
      countDistinctPoints({Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(0.0205f, 0, 0)}, kRadiusM), 2);
  EXPECT_EQ(countDistinctPoints({}, kRadiusM), 0);
  // Negative coordinates.
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(-0.001f, -5, -5), Eigen::Vector3f(0.001f, -5, -5)},
                                kRadiusM),
            1);
}

TEST(LandmarkMetrics, PatchStdDevIsTheGreyLevelSpreadOfTheClippedPatch) {
  constexpr double kTol = 1e-9;
  ImageU8 image(20, 10, 100);
  EXPECT_NEAR(patchStdDevGrey(image, 10, 5, kTexturePatchRadius), 0.0, kTol);  // plain
  // Columns alternating 90 (even) / 110 (odd): the 7x7 patch at (10, 5) spans columns 7..13,
  // four odd and three even.
  for (int v = 0; v < image.height; ++v) {
    for (int u = 0; u < image.width; ++u) image(u, v) = (u % 2) ? 110 : 90;
  }
  const double mean = (3.0 * 90 + 4.0 * 110) / 7.0;
  const double expected =
      std::sqrt((3.0 * (90 - mean) * (90 - mean) + 4.0 * (110 - mean) * (110 - mean)) / 7.0);
  EXPECT_NEAR(patchStdDevGrey(image, 10, 5, kTexturePatchRadius), expected, kTol);
  EXPECT_NEAR(
      patchStdDevGrey(image, 10.3, 4.8, kTexturePatchRadius), expected, kTol);  // nearest pixel
  // At the corner the patch is clipped to 4x4 (columns 0..3: two of each): std exactly 10.
  EXPECT_NEAR(patchStdDevGrey(image, 0, 0, kTexturePatchRadius), 10.0, kTol);
  // Outside the image: NaN, not a read out of bounds.
  EXPECT_TRUE(std::isnan(patchStdDevGrey(image, -1, 5, kTexturePatchRadius)));
  EXPECT_TRUE(std::isnan(patchStdDevGrey(image, 10, 10, kTexturePatchRadius)));
  EXPECT_TRUE(std::isnan(patchStdDevGrey(ImageU8(), 0, 0, kTexturePatchRadius)));
}

}  // namespace
}  // namespace twocam::eval

namespace twocam::eval {
namespace {

/// A hand-built database state for the evaluator: a small rig, a depth image with a vertical
/// depth edge (near wall left of column 32, far wall from it), and landmarks placed on purpose.
class HandBuiltRun : public ::testing::Test {
 protected:
  static constexpr float kNearZ = 2.0f;  // d = fx B / z = 25 px
  static constexpr float kFarZ = 4.0f;   // 12.5 px
  static constexpr int kEdgeColumn = 32;

  static StereoRig smallRig() {
    StereoRig rig;
    rig.width_px = 64;
    rig.height_px = 48;
    rig.fx_px = rig.fy_px = 500.0;
    rig.cx_px = 31.5;
    rig.cy_px = 23.5;
    rig.baseline_m = 0.1;
    return rig;
  }

  HandBuiltRun() : rig_(smallRig()), depth_(64, 48, kNearZ), left_(64, 48, 100), evaluator_(rig_) {
    for (int v = 0; v < depth_.height; ++v) {
      for (int u = kEdgeColumn; u < depth_.width; ++u) depth_(u, v) = kFarZ;
    }
  }

  /// Adds a landmark anchored at (u, v) in `frame`, placed on the anchor ray at depth z_m.
  uint32_t add(landmarks::LandmarkState state,
               float u,
               float v,
               double z_m,
               double confidence,
               int32_t frame) {
    landmarks::Landmark l;
    l.id = static_cast<uint64_t>(slots_.size()) + 100;
    l.state = state;
    l.confidence = confidence;
    l.first_frame = frame;
    l.confirmed_frame = state == landmarks::LandmarkState::kConfirmed ? frame + 3 : -1;
    l.anchor.frame = frame;
    l.anchor.u_px = u;
    l.anchor.v_px = v;
    l.anchor.d_px = static_cast<float>(rig_.fx_px * rig_.baseline_m / z_m);
    const Eigen::Vector3d ray((u - rig_.cx_px) / rig_.fx_px, (v - rig_.cy_px) / rig_.fy_px, 1.0);
    l.p_w = landmarks::cameraPoseInWorld(l.anchor.odom_pose, rig_.T_b_cl) * (ray * z_m);
    slots_.push_back(l);
    return static_cast<uint32_t>(slots_.size() - 1);
  }

  Status frame(int32_t index, const std::vector<uint32_t>& created) {
    landmarks::FrameReport report;
    report.frame = index;
    for (uint32_t k : created) report.created_ids.push_back(slots_[k].id);
    return evaluator_.addFrame(StereoHypotheses{}, left_, report, finder(), depth_, T_w_b_);
  }

  /// Looks a hand-built landmark up by id, as LandmarkDatabase::find does.
  std::function<const landmarks::Landmark*(uint64_t)> finder() const {
    return [this](uint64_t id) -> const landmarks::Landmark* {
      for (const landmarks::Landmark& l : slots_)
        if (l.id == id) return &l;
      return nullptr;
    };
  }

  StereoRig rig_;
  ImageF32 depth_;
  ImageU8 left_;
  Eigen::Isometry3d T_w_b_ = Eigen::Isometry3d::Identity();
  std::vector<landmarks::Landmark> slots_;
  LandmarkEvaluator evaluator_;
};

TEST_F(HandBuiltRun, PrecisionJudgesDepthEdgesByTheNearAndFarSurface) {
  using landmarks::LandmarkState;
  constexpr auto kC = LandmarkState::kConfirmed;
  const uint32_t right = add(kC, 10, 20, kNearZ, 0.96, 0);
  const uint32_t wrong = add(kC, 12, 20, 2.5, 0.75, 0);  // 20 px against 25 px of truth
  // Anchors on the edge (columns 31 and 32 see both walls in their 3x3): no ground truth.
  const uint32_t near_side = add(kC, 31, 20, kNearZ, 0.9, 0);
  const uint32_t far_side = add(kC, 32, 20, kFarZ, 0.9, 0);
  const uint32_t mixed = add(kC, 31, 30, 3.0, 0.9, 0);  // 16.7 px: on neither surface
  const uint32_t candidate = add(LandmarkState::kCandidate, 50, 10, kFarZ, 0.6, 0);
  ASSERT_TRUE(frame(0, {right, wrong, near_side, far_side, mixed, candidate}).isOk());
  // The same physical point confirmed again from frame 1 (0.2 px away: < 1 mm at 2 m).
  const uint32_t again = add(kC, 10.2f, 20, kNearZ, 0.99, 1);
  ASSERT_TRUE(frame(1, {again}).isOk());

  EXPECT_EQ(evaluator_.verdict(slots_[right]), 1);
  EXPECT_EQ(evaluator_.verdict(slots_[wrong]), 0);
  EXPECT_EQ(evaluator_.verdict(slots_[near_side]), -1);
  EXPECT_EQ(evaluator_.verdict(slots_[far_side]), -1);
  EXPECT_EQ(evaluator_.verdict(slots_[mixed]), -1);

  const LandmarkMetrics m = evaluator_.finish(slots_);
  constexpr double kPercentTol = 1e-9;  // ratios of small integers
  EXPECT_EQ(m.confirmed, 6);
  EXPECT_EQ(m.candidates, 1);
  EXPECT_EQ(m.unjudged_confirmed, 3);
  EXPECT_EQ(m.unjudged_near_side, 1);
  EXPECT_EQ(m.unjudged_far_side, 1);
  EXPECT_EQ(m.unjudged_neither, 1);
  EXPECT_EQ(m.correct_confirmed_strict, 2);  // right, again
  EXPECT_EQ(m.correct_confirmed, 4);         // + near side + far side; the mixed one is wrong
  EXPECT_NEAR(m.precision, 100.0 * 4 / 6, kPercentTol);
  EXPECT_NEAR(m.precision_strict, 100.0 * 2 / 6, kPercentTol);
  EXPECT_NEAR(m.precision_judged, 100.0 * 2 / 3, kPercentTol);
  // `right` and `again` are one physical point.
  EXPECT_EQ(m.correct_distinct_points, 1);

  // Calibration over judged landmarks (confirmed or not): right 0.96 ok, wrong 0.75, again 0.99
  // ok, candidate 0.6 ok.
  ASSERT_EQ(m.calibration.size(), 7u);
  const auto row = [&](double threshold) {
    for (const CalibrationRow& r : m.calibration) {
      if (r.threshold == threshold) return r;
    }
    ADD_FAILURE() << "no row " << threshold;
    return CalibrationRow{};
  };
  EXPECT_EQ(row(0.0).landmarks, 4);
  EXPECT_EQ(row(0.0).correct, 3);
  EXPECT_NEAR(row(0.0).precision, 75.0, kPercentTol);
  EXPECT_EQ(row(0.7).landmarks, 3);
  EXPECT_EQ(row(0.7).correct, 2);
  EXPECT_EQ(row(0.8).landmarks, 2);
  EXPECT_NEAR(row(0.8).precision, 100.0, kPercentTol);
  EXPECT_EQ(row(0.95).landmarks, 2);
  EXPECT_EQ(row(0.99).landmarks, 1);

  // The JSON schema carries both definitions.
  const io::Json j = toJson(m);
  EXPECT_EQ(j["landmarks"]["correct_confirmed"].get<int64_t>(), 4);
  EXPECT_EQ(j["landmarks"]["correct_confirmed_strict"].get<int64_t>(), 2);
  EXPECT_NEAR(j["landmarks"]["precision_strict"].get<double>(), 100.0 * 2 / 6, kPercentTol);
}

TEST_F(HandBuiltRun, DuplicatesAreConfirmationsOfAnOlderConfirmedLandmarksPoint) {
  using landmarks::LandmarkState;
  constexpr auto kC = LandmarkState::kConfirmed;
  const auto confirm_frame = [&](int32_t index,
                                 const std::vector<uint32_t>& created,
                                 const std::vector<uint32_t>& confirmed,
                                 const std::vector<uint32_t>& removed = {}) {
    landmarks::FrameReport report;
    report.frame = index;
    for (uint32_t k : created) report.created_ids.push_back(slots_[k].id);
    for (uint32_t k : confirmed) report.confirmed_ids.push_back(slots_[k].id);
    for (uint32_t k : removed) report.removed_ids.push_back(slots_[k].id);
    return evaluator_.addFrame(StereoHypotheses{}, left_, report, finder(), depth_, T_w_b_);
  };
  const uint32_t first = add(kC, 10, 20, kNearZ, 0.9, 0);
  const uint32_t elsewhere = add(kC, 20, 10, kNearZ, 0.9, 0);
  ASSERT_TRUE(confirm_frame(0, {first, elsewhere}, {first, elsewhere}).isOk());
  // Frame 1: the same point again (0.6 px away), and a new point 3 px away: one duplicate.
  const uint32_t again = add(kC, 10.6f, 20, kNearZ, 0.9, 1);
  slots_[first].last_seen_frame = 1;  // `first` was associated in frame 1 too
  const uint32_t beside = add(kC, 13, 20, kNearZ, 0.9, 1);
  ASSERT_TRUE(confirm_frame(1, {again, beside}, {again, beside}).isOk());
  // Frame 2: `elsewhere` was removed; its point confirmed again is not a duplicate any more
  // (nothing older is still known there).
  const uint32_t back = add(kC, 20, 10, kNearZ, 0.9, 2);
  ASSERT_TRUE(confirm_frame(2, {back}, {back}, {elsewhere}).isOk());
  slots_[elsewhere].state = LandmarkState::kFree;
  const LandmarkMetrics m = evaluator_.finish(slots_);
  EXPECT_EQ(m.confirmations_judged, 5);
  EXPECT_EQ(m.duplicates, 1);
  EXPECT_DOUBLE_EQ(m.duplicate_fraction, 0.2);
  // The record names the older landmark at the point, as the database had it then.
  ASSERT_EQ(evaluator_.duplicateRecords().size(), 1u);
  const DuplicateRecord& r = evaluator_.duplicateRecords()[0];
  EXPECT_EQ(r.frame, 1);
  EXPECT_EQ(r.id, slots_[again].id);
  EXPECT_EQ(r.first_frame, 1);
  EXPECT_EQ(r.older_id, slots_[first].id);
  EXPECT_EQ(r.older_first_frame, 0);
  EXPECT_EQ(r.older_confirmed_frame, 3);  // add(): confirmed three frames after seeding
  EXPECT_EQ(r.older_last_seen_frame, 1);
  // Every landmark sits at its true point (identity poses): map error 0 up to float rounding.
  constexpr double kFloatPointTolM = 1e-6;
  EXPECT_NEAR(m.map_error_median_m, 0.0, kFloatPointTolM);
  EXPECT_NEAR(m.map_error_p90_m, 0.0, kFloatPointTolM);
}

TEST_F(HandBuiltRun, MapErrorIsTheDistanceToTheTruePointInTheTrueWorld) {
  using landmarks::LandmarkState;
  const uint32_t a = add(LandmarkState::kConfirmed, 10, 20, kNearZ, 0.9, 0);
  const uint32_t b = add(LandmarkState::kConfirmed, 20, 20, kNearZ, 0.9, 0);
  const uint32_t c = add(LandmarkState::kConfirmed, 15, 30, kNearZ, 0.9, 0);
  ASSERT_TRUE(frame(0, {a, b, c}).isOk());
  // The map holds them 5 cm, 1 m and 10 cm off (e.g. placed with a drifted pose).
  slots_[a].p_w += Eigen::Vector3d(0.05, 0.0, 0.0);
  slots_[b].p_w += Eigen::Vector3d(0.0, 1.0, 0.0);
  slots_[c].p_w += Eigen::Vector3d(0.0, 0.0, -0.1);
  const LandmarkMetrics m = evaluator_.finish(slots_);
  constexpr double kFloatPointTolM = 1e-6;
  EXPECT_NEAR(m.map_error_median_m, 0.1, kFloatPointTolM);
  EXPECT_NEAR(m.map_error_p90_m, 1.0, kFloatPointTolM);
  // No confirmation was reported through confirmed_ids: the fraction is absent, not 0.
  EXPECT_TRUE(std::isnan(m.duplicate_fraction));
}

TEST_F(HandBuiltRun, RemovedLandmarksAreForgotten) {
  const uint32_t a = add(landmarks::LandmarkState::kConfirmed, 10, 20, kNearZ, 0.9, 0);
  ASSERT_TRUE(frame(0, {a}).isOk());
  landmarks::FrameReport report;
  report.frame = 1;
  report.removed_ids = {slots_[a].id};
  ASSERT_TRUE(
      evaluator_.addFrame(StereoHypotheses{}, left_, report, finder(), depth_, T_w_b_).isOk());
  EXPECT_EQ(evaluator_.verdict(slots_[a]), -1);
}

TEST_F(HandBuiltRun, NonFiniteOrHugeGroundTruthPoseIsAnError) {
  const uint32_t a = add(landmarks::LandmarkState::kConfirmed, 10, 20, kNearZ, 0.9, 0);
  T_w_b_.translation().x() = std::numeric_limits<double>::quiet_NaN();
  const Status nan = frame(0, {a});
  EXPECT_FALSE(nan.isOk());
  EXPECT_NE(nan.message().find("not finite"), std::string::npos) << nan.message();
  EXPECT_NE(nan.message().find("frame 0"), std::string::npos) << nan.message();
  T_w_b_.translation().x() = 1e12;
  const Status huge = frame(0, {a});
  EXPECT_FALSE(huge.isOk());
  EXPECT_NE(huge.message().find("from the origin"), std::string::npos) << huge.message();
  T_w_b_.translation().x() = 0.0;
  T_w_b_.linear()(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(frame(0, {a}).isOk());
}

TEST(LandmarkMetrics, DistinctPointsSkipNonFiniteAndHandleHugePoints) {
  constexpr double kRadiusM = 0.02;
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  constexpr float kHuge = 1e30f;  // far beyond int cell indices: no overflow, still compared
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(kNaN, 0, 0),
                                 Eigen::Vector3f(0, 0, std::numeric_limits<float>::infinity()),
                                 Eigen::Vector3f(0, 0, 0)},
                                kRadiusM),
            1);
  EXPECT_EQ(countDistinctPoints({Eigen::Vector3f(kHuge, 0, 0),
                                 Eigen::Vector3f(kHuge, 0, 0),
                                 Eigen::Vector3f(-kHuge, 0, 0),
                                 Eigen::Vector3f(0, -kHuge, kHuge)},
                                kRadiusM),
            3);
}

}  // namespace
}  // namespace twocam::eval
