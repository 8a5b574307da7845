#include "landmarks/landmark_database.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <optional>

#include "landmarks/landmark_model.h"
#include "landmarks/refine.h"
#include "support/synthetic_stream.h"

namespace twocam::landmarks {
namespace {

using test::SyntheticFrame;
using test::SyntheticStream;
using test::SyntheticStreamOptions;

/// Outcome of a synthetic run: confirmed landmarks split by the truth of their anchor hypothesis.
struct RunOutcome {
  int confirmed = 0;
  int correct = 0;
  double max_correct_error_m = 0.0;
  int final_candidates = 0;
  int final_slots = 0;
  int wrong_periodic = 0;
  int wrong_random = 0;
  /// Confirmed landmarks whose anchor's world point already has another confirmed landmark.
  int duplicates = 0;
  /// World points with at least one correct confirmed landmark.
  int distinct_correct = 0;
  /// Candidates fused into a confirmed landmark at confirmation, corners reclaimed at seeding.
  int fused = 0;
  int reclaimed = 0;
};

/// How runSynthetic drives the database as a localising pipeline would: each frame predicted
/// with the true pose moved sideways by prediction_offset_m and a small covariance
/// (setPredictionSigma), then corrected to the true pose (correctFramePose with that sigma).
struct Localized {
  double prediction_offset_m = 0.0;
  OdometryErrorSigma sigma{0.005, 0.002};  // a pose held by vision: 5 mm, 0.1 degree
  int* reassociated = nullptr;             // receives the second pass's finds
};

/// The synthetic stream through the database with odometry poses (update()), or localised.
RunOutcome runSynthetic(const SyntheticStreamOptions& stream_options,
                        const LandmarkOptions& options,
                        int frames,
                        const Localized* localized = nullptr) {
  const StereoRig rig = SyntheticStream::defaultRig();
  SyntheticStream stream(rig, stream_options);
  LandmarkDatabase db(rig, options);
  std::map<uint64_t, std::pair<int, int32_t>> anchor_truth;  // id -> (kind, world point)
  SyntheticFrame frame;
  FrameReport report;
  int fused = 0, reclaimed = 0;
  for (int k = 0; k < frames; ++k) {
    stream.next(&frame);
    if (localized == nullptr) {
      const Status s =
          db.update(frame.frame, frame.t_ns, frame.odom_pose, frame.hypotheses, &report);
      EXPECT_TRUE(s.isOk()) << s.message();
    } else {
      Pose2 predicted = frame.true_pose;
      predicted.x_m -= localized->prediction_offset_m * std::sin(predicted.yaw_rad);
      predicted.y_m += localized->prediction_offset_m * std::cos(predicted.yaw_rad);
      db.setPredictionSigma(k > 0 ? std::optional<OdometryErrorSigma>(localized->sigma)
                                  : std::nullopt);
      EXPECT_TRUE(
          db.beginFrame(frame.frame, frame.t_ns, predicted, frame.hypotheses, &report).isOk());
      EXPECT_TRUE(db.correctFramePose(frame.true_pose, localized->sigma).isOk());
      db.finishFrame();
      if (localized->reassociated != nullptr) *localized->reassociated += report.reassociated;
    }
    fused += report.fused;
    reclaimed += report.reclaimed;
    for (uint64_t id : report.removed_ids) anchor_truth.erase(id);
    for (size_t i = 0; i < report.created_ids.size(); ++i) {
      const uint32_t j = report.created_hypotheses[i];
      anchor_truth[report.created_ids[i]] = {frame.hypothesis_kind[j], frame.hypothesis_point[j]};
    }
  }
  RunOutcome out;
  out.fused = fused;
  out.reclaimed = reclaimed;
  std::map<int32_t, int> confirmed_per_point;
  std::map<int32_t, int> correct_per_point;
  for (const Landmark& l : db.landmarks()) {
    if (l.state == LandmarkState::kFree) continue;
    ++out.final_slots;
    if (l.state != LandmarkState::kConfirmed) continue;
    ++out.confirmed;
    const auto it = anchor_truth.find(l.id);
    if (it == anchor_truth.end()) continue;
    if (confirmed_per_point[it->second.second]++ > 0) ++out.duplicates;
    if (it->second.first == 1) ++out.wrong_periodic;
    if (it->second.first == 2) ++out.wrong_random;
    if (it->second.first != 0) continue;
    ++out.correct;
    if (correct_per_point[it->second.second]++ == 0) ++out.distinct_correct;
    // The odometry world frame drifts from the true one; compare in the anchor camera instead.
    const Eigen::Vector3d p_anchor =
        cameraPoseInWorld(l.anchor.odom_pose, rig.T_b_cl).inverse() * l.p_w;
    const auto p_true =
        triangulateRectified(rig, Eigen::Vector2d(l.anchor.u_px, l.anchor.v_px), l.anchor.d_px);
    out.max_correct_error_m =
        std::max(out.max_correct_error_m, (p_anchor - *p_true).norm() / p_true->z());
  }
  out.final_candidates = db.numCandidates();
  return out;
}

// Precision the consistency policy must reach on the synthetic stream (issue: >= 99.5 % on office).
constexpr double kMinPrecision = 0.995;
/// Twins as rivals split one point's belief and verify only where a lucky sub-pixel spread lets
/// motion separate them; as one answer they confirm like single matches (measured on seed 7:
/// 2629 correct against 103; the margin keeps the test about the rule, not the stream's figures).
constexpr double kMinTwinGain = 5.0;

TEST(LandmarkDatabase, ConsistencyConfirmsRealLandmarksAndRejectsRivals) {
  SyntheticStreamOptions so;
  so.seed = 7;
  LandmarkOptions options;
  const RunOutcome out = runSynthetic(so, options, 300);
  ASSERT_GT(out.confirmed, 300) << "too few confirmations to judge precision";
  std::printf("consistency on the synthetic stream: %d confirmed, %d correct\n",
              out.confirmed,
              out.correct);
  EXPECT_GE(static_cast<double>(out.correct) / out.confirmed, kMinPrecision)
      << out.correct << " correct of " << out.confirmed << "; wrong: " << out.wrong_periodic
      << " periodic, " << out.wrong_random << " random";
}

// When the frontend says a corner's list holds every candidate disparity, a candidate needs to
// be told only from its own rivals (LandmarkOptions::verify_own_rivals): a side without a rival
// needs no evidence. On the synthetic stream, whose lists always hold the real match, that
// confirms more landmarks, still all correct.
TEST(LandmarkDatabase, CompleteListsAreVerifiedAgainstTheirOwnRivals) {
  SyntheticStreamOptions so;
  so.seed = 7;
  const LandmarkOptions options;
  const RunOutcome generic = runSynthetic(so, options, 300);
  so.complete_lists = true;
  const RunOutcome own = runSynthetic(so, options, 300);
  LandmarkOptions off = options;
  off.consistency.verify_own_rivals = false;
  const RunOutcome ignored = runSynthetic(so, off, 300);
  std::printf("confirmed (correct): generic phantoms %d (%d), own rivals %d (%d)\n",
              generic.confirmed,
              generic.correct,
              own.confirmed,
              own.correct);
  EXPECT_GT(own.correct, generic.correct);
  EXPECT_GE(static_cast<double>(own.correct) / own.confirmed, kMinPrecision)
      << "wrong: " << own.wrong_periodic << " periodic, " << own.wrong_random << " random";
  // With the option off, the flag changes nothing.
  EXPECT_EQ(ignored.confirmed, generic.confirmed);
  EXPECT_EQ(ignored.correct, generic.correct);
}

// A disparity the frontend lists twice (two cost curves, sub-pixel fits up to 0.6 px apart) is
// one answer (LandmarkOptions::same_answer_px): seeded once, and never a phantom to be told
// apart by motion, which cannot.
TEST(LandmarkDatabase, TwinHypothesesAreTheSameAnswer) {
  SyntheticStreamOptions so;
  so.seed = 7;
  so.complete_lists = true;
  so.twin_prob = 1.0;
  const LandmarkOptions options;
  const RunOutcome same = runSynthetic(so, options, 300);
  LandmarkOptions strict = options;
  strict.consistency.same_answer_px = 0.0;
  const RunOutcome apart = runSynthetic(so, strict, 300);
  std::printf(
      "every real match listed twice, confirmed (correct): twins the same answer %d (%d), "
      "twins as phantoms %d (%d)\n",
      same.confirmed,
      same.correct,
      apart.confirmed,
      apart.correct);
  EXPECT_GT(same.correct, kMinTwinGain * apart.correct);
  EXPECT_GE(static_cast<double>(same.correct) / same.confirmed, kMinPrecision)
      << "wrong: " << same.wrong_periodic << " periodic, " << same.wrong_random << " random";
}

TEST(LandmarkDatabase, WinnerTakesAllKeepsSpuriousBestMatches) {
  // The baseline accepts the best match at once; with rivals winning 30 % of the time its
  // precision must be clearly below the consistency policy's, or the experiment is pointless.
  SyntheticStreamOptions so;
  so.seed = 7;
  LandmarkOptions options;
  options.policy = Policy::kWtaLrc;
  const RunOutcome out = runSynthetic(so, options, 150);
  ASSERT_GT(out.confirmed, 100);
  EXPECT_LT(static_cast<double>(out.correct) / out.confirmed, 0.95);
}

TEST(LandmarkDatabase, EveryPolicyRunsAndConfirmsSomething) {
  for (Policy policy : allPolicies()) {
    SyntheticStreamOptions so;
    so.seed = 3;
    LandmarkOptions options;
    options.policy = policy;
    const RunOutcome out = runSynthetic(so, options, 120);
    EXPECT_GT(out.confirmed, 0) << policyName(policy);
  }
}

TEST(LandmarkDatabase, SameSeedSameResult) {
  SyntheticStreamOptions so;
  so.seed = 11;
  const StereoRig rig = SyntheticStream::defaultRig();
  std::vector<std::vector<double>> results(2);
  for (int run = 0; run < 2; ++run) {
    SyntheticStream stream(rig, so);
    LandmarkDatabase db(rig, LandmarkOptions());
    SyntheticFrame frame;
    FrameReport report;
    for (int k = 0; k < 80; ++k) {
      stream.next(&frame);
      ASSERT_TRUE(
          db.update(frame.frame, frame.t_ns, frame.odom_pose, frame.hypotheses, &report).isOk());
    }
    for (const Landmark& l : db.landmarks()) {
      if (l.state == LandmarkState::kFree) continue;
      results[run].insert(results[run].end(),
                          {static_cast<double>(l.id),
                           l.p_w.x(),
                           l.p_w.y(),
                           l.p_w.z(),
                           static_cast<double>(l.confidence)});
    }
  }
  EXPECT_EQ(results[0], results[1]);
}

/// A database (default options) that has taken frame 0 of the default synthetic stream.
struct AfterFirstFrame {
  StereoRig rig = SyntheticStream::defaultRig();
  SyntheticStream stream{rig, SyntheticStreamOptions()};
  LandmarkDatabase db{rig, LandmarkOptions()};
  SyntheticFrame frame;
  FrameReport report;
  Status status;
  AfterFirstFrame() {
    stream.next(&frame);
    status = db.update(0, frame.t_ns, frame.odom_pose, frame.hypotheses, &report);
  }
};

TEST(LandmarkDatabase, RejectsBadOdometryAndTimeWithoutChangingState) {
  AfterFirstFrame first;
  ASSERT_TRUE(first.status.isOk()) << first.status.message();
  LandmarkDatabase& db = first.db;
  const SyntheticFrame& frame = first.frame;
  FrameReport& report = first.report;
  const int candidates = db.numCandidates();
  ASSERT_GT(candidates, 0);
  Pose2 nan_pose = frame.odom_pose;
  nan_pose.x_m = std::numeric_limits<double>::quiet_NaN();
  Status s = db.update(1, frame.t_ns + 1, nan_pose, frame.hypotheses, &report);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("not finite"), std::string::npos) << s.message();
  Pose2 inf_pose = frame.odom_pose;
  inf_pose.yaw_rad = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(db.update(1, frame.t_ns + 1, inf_pose, frame.hypotheses, &report).isOk());
  s = db.update(1, frame.t_ns - 1, frame.odom_pose, frame.hypotheses, &report);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("backwards"), std::string::npos) << s.message();
  EXPECT_FALSE(db.update(0, frame.t_ns + 1, frame.odom_pose, frame.hypotheses, &report).isOk());
  StereoHypotheses broken = frame.hypotheses;
  broken.hypotheses[0].point_index = 1u << 30;
  EXPECT_FALSE(db.update(1, frame.t_ns + 1, frame.odom_pose, broken, &report).isOk());
  EXPECT_EQ(db.numCandidates(), candidates);
}

TEST(LandmarkDatabase, EmptyFramesAndStandingStillAreHandled) {
  const StereoRig rig = SyntheticStream::defaultRig();
  SyntheticStream stream(rig, SyntheticStreamOptions());
  LandmarkDatabase db(rig, LandmarkOptions());
  SyntheticFrame frame;
  FrameReport report;
  stream.next(&frame);
  // Thirty frames at the same pose: spurious matches reappear exactly like real ones, so nothing
  // may be confirmed without motion.
  for (int k = 0; k < 30; ++k) {
    ASSERT_TRUE(db.update(k, frame.t_ns + k, frame.odom_pose, frame.hypotheses, &report).isOk());
  }
  EXPECT_EQ(db.numConfirmed(), 0);
  // A frame without hypotheses is fine too; candidates get a miss.
  ASSERT_TRUE(db.update(30, frame.t_ns + 30, frame.odom_pose, StereoHypotheses(), &report).isOk());
  EXPECT_EQ(report.associated, 0);
  EXPECT_GT(report.predicted_visible, 0);
}

TEST(LandmarkDatabase, CornersOnDepthEdgesAreNotSeededUnlessAsked) {
  const StereoRig rig = SyntheticStream::defaultRig();
  SyntheticStream stream(rig, SyntheticStreamOptions());
  SyntheticFrame frame;
  stream.next(&frame);
  ASSERT_GT(frame.hypotheses.points.size(), 10u);
  // Mark every other point's best hypothesis as matched by a window shifted off the corner.
  StereoHypotheses edged = frame.hypotheses;
  size_t marked = 0;
  for (size_t i = 0; i < edged.points.size(); i += 2) {
    const SalientPoint& p = edged.points[i];
    if (p.num_hypotheses == 0) continue;
    edged.hypotheses[p.first_hypothesis].window_shift_px = 5;
    ++marked;
  }
  ASSERT_GT(marked, 0u);
  FrameReport plain_report;
  LandmarkDatabase plain(rig, LandmarkOptions());
  ASSERT_TRUE(plain.update(0, frame.t_ns, frame.odom_pose, frame.hypotheses, &plain_report).isOk());
  FrameReport edged_report;
  LandmarkDatabase edged_db(rig, LandmarkOptions());
  ASSERT_TRUE(edged_db.update(0, frame.t_ns, frame.odom_pose, edged, &edged_report).isOk());
  LandmarkOptions keep;
  keep.tracker.seed_depth_edges = true;
  FrameReport keep_report;
  LandmarkDatabase keep_db(rig, keep);
  ASSERT_TRUE(keep_db.update(0, frame.t_ns, frame.odom_pose, edged, &keep_report).isOk());
  EXPECT_LT(edged_db.numCandidates(), plain.numCandidates());
  EXPECT_EQ(keep_db.numCandidates(), plain.numCandidates());
  // No candidate of the edged database is anchored on a marked point.
  for (const Landmark& l : edged_db.landmarks()) {
    if (l.state == LandmarkState::kFree) continue;
    for (size_t i = 0; i < edged.points.size(); i += 2) {
      const Corner& c = edged.points[i].corner;
      EXPECT_FALSE(l.anchor.u_px == c.u_px && l.anchor.v_px == c.v_px) << "point " << i;
    }
  }
}

TEST(LandmarkDatabase, CandidatesWithoutRowSupportAreNotConfirmed) {
  // Every hypothesis of the even world points is marked as lacking row support in every frame
  // (as the frontend reports a match whose neighbouring rows disagree): (almost) none of them
  // may be confirmed, while the odd points are confirmed as before; with the rule off both are.
  const StereoRig rig = SyntheticStream::defaultRig();
  auto run = [&rig](const LandmarkOptions& options, int* confirmed_even, int* confirmed_odd) {
    SyntheticStream stream(rig, SyntheticStreamOptions());
    LandmarkDatabase db(rig, options);
    std::map<uint64_t, int32_t> anchor_point;  // id -> world point of the anchor hypothesis
    SyntheticFrame frame;
    FrameReport report;
    for (int k = 0; k < 150; ++k) {
      stream.next(&frame);
      for (size_t j = 0; j < frame.hypotheses.hypotheses.size(); ++j) {
        const int32_t point = frame.hypothesis_point[j];
        frame.hypotheses.hypotheses[j].row_span_px = point >= 0 && point % 2 == 0 ? 3.0f : 0.1f;
      }
      ASSERT_TRUE(
          db.update(frame.frame, frame.t_ns, frame.odom_pose, frame.hypotheses, &report).isOk());
      for (uint64_t id : report.removed_ids) anchor_point.erase(id);
      for (size_t i = 0; i < report.created_ids.size(); ++i) {
        anchor_point[report.created_ids[i]] = frame.hypothesis_point[report.created_hypotheses[i]];
      }
    }
    *confirmed_even = *confirmed_odd = 0;
    for (const Landmark& l : db.landmarks()) {
      if (l.state != LandmarkState::kConfirmed) continue;
      const auto it = anchor_point.find(l.id);
      ASSERT_NE(it, anchor_point.end());
      if (it->second < 0) continue;
      ++(it->second % 2 == 0 ? *confirmed_even : *confirmed_odd);
    }
  };
  int even = 0;
  int odd = 0;
  run(LandmarkOptions(), &even, &odd);
  // An even-point candidate can only be confirmed when at least 9 in 10 of its observations
  // were hypotheses of other (odd) points: a track that hopped to a neighbour, which is rare.
  EXPECT_LE(even, odd / 50);
  EXPECT_GT(odd, 100);
  LandmarkOptions off;
  off.consistency.max_row_unsupported_fraction = 1.0;
  int even_off = 0;
  int odd_off = 0;
  run(off, &even_off, &odd_off);
  EXPECT_GT(even_off, 100);
  EXPECT_NEAR(odd_off, odd, 0.2 * odd);
  // A wider bound lets the 3 px spans pass.
  LandmarkOptions wide;
  wide.consistency.max_row_span_px = 5.0;
  int even_wide = 0;
  int odd_wide = 0;
  run(wide, &even_wide, &odd_wide);
  EXPECT_EQ(even_wide, even_off);
  EXPECT_EQ(odd_wide, odd_off);
}

TEST(LandmarkDatabase, RevisitedLandmarksAreReassociatedNotDuplicated) {
  // 2000 frames = 4 laps of the circle with exact odometry: confirmed landmarks that leave the
  // view must be re-associated when they come back, so the map cannot outgrow the world.
  SyntheticStreamOptions so;
  so.seed = 5;
  so.num_points = 1500;
  so.odom_sigma_per_m = so.odom_sigma_per_rad = so.odom_scale_error = so.odom_wheel_base_error =
      0.0;
  const StereoRig rig = SyntheticStream::defaultRig();
  SyntheticStream stream(rig, so);
  LandmarkDatabase db(rig, LandmarkOptions());
  SyntheticFrame frame;
  FrameReport report;
  int max_candidates = 0;
  for (int k = 0; k < 2000; ++k) {
    stream.next(&frame);
    ASSERT_TRUE(
        db.update(frame.frame, frame.t_ns, frame.odom_pose, frame.hypotheses, &report).isOk());
    max_candidates = std::max(max_candidates, db.numCandidates());
  }
  EXPECT_GT(db.numConfirmed(), 500);
  EXPECT_LE(db.numConfirmed(), so.num_points);
  // Candidates live a few frames: bounded by a few frames' worth of hypotheses (<= ~500 here).
  EXPECT_LT(max_candidates, 2000);
  EXPECT_LE(db.landmarks().size(), static_cast<size_t>(so.num_points + max_candidates));
}

/// The landmark benchmark's stream: an 8 x 8 m room, 8000 points, half of them detected per
/// frame, random rivals, odometry drift.
SyntheticStreamOptions driftingStream() {
  SyntheticStreamOptions so;
  so.seed = 20261129;
  so.num_points = 8000;
  so.half_x_m = so.half_y_m = 4.0;
  so.detection_prob = 0.5;
  so.random_rival_prob = 0.6;
  return so;
}

TEST(LandmarkDatabase, DriftDoesNotBreedDuplicateConfirmedLandmarks) {
  // The landmark benchmark's stream (8 x 8 m room, 8000 points, odometry drift): after six laps a
  // confirmed landmark coming back into view finds several corners in its drift-widened gate.
  // Taking the nearest one let it live on a neighbour while its own corner was confirmed again,
  // so duplicates grew with every lap.
  const SyntheticStreamOptions so = driftingStream();
  constexpr int kShort = 1000;
  constexpr int kFrames = 3000;
  // Tolerances. Some duplicates remain at any time: a landmark whose gate is ambiguous is not
  // associated, its corner is confirmed afresh and the old one waits out max_confirmed_misses
  // (measured 7.8 % with verification by summed evidence, 8.7 % before, 3.6 % when evidence was
  // counted every other frame). What must not happen is growth: over the last 2000 frames they
  // may rise by at most 2 % of the confirmed landmarks (measured: 132 -> 125; taking the nearest
  // corner: 404 -> 1556).
  constexpr double kMaxDuplicateFraction = 0.10;
  constexpr double kMaxDuplicateGrowth = 0.02;
  const RunOutcome early = runSynthetic(so, LandmarkOptions(), kShort);
  const RunOutcome with_rule = runSynthetic(so, LandmarkOptions(), kFrames);
  LandmarkOptions nearest;
  nearest.consistency.unambiguous_confirmed_hits = false;
  const RunOutcome early_without = runSynthetic(so, nearest, kShort);
  const RunOutcome without_rule = runSynthetic(so, nearest, kFrames);
  std::printf(
      "duplicates on the drifting stream: %d of %d confirmed at frame %d, %d of %d at frame %d; "
      "taking the nearest corner: %d of %d, %d of %d\n",
      early.duplicates,
      early.confirmed,
      kShort,
      with_rule.duplicates,
      with_rule.confirmed,
      kFrames,
      early_without.duplicates,
      early_without.confirmed,
      without_rule.duplicates,
      without_rule.confirmed);
  ASSERT_GT(with_rule.confirmed, 100);
  EXPECT_LT(with_rule.duplicates, kMaxDuplicateFraction * with_rule.confirmed)
      << with_rule.duplicates << " of " << with_rule.confirmed;
  EXPECT_LE(with_rule.duplicates, early.duplicates + kMaxDuplicateGrowth * with_rule.confirmed)
      << early.duplicates << " at frame " << kShort << ", " << with_rule.duplicates << " at "
      << kFrames;
  // The same run taking the nearest corner breeds them (this is what the rule prevents).
  EXPECT_GT(without_rule.duplicates, 4 * with_rule.duplicates + 50)
      << without_rule.duplicates << " of " << without_rule.confirmed;
  EXPECT_GT(without_rule.duplicates, 2 * early_without.duplicates)
      << early_without.duplicates << " at frame " << kShort << ", " << without_rule.duplicates
      << " at " << kFrames;
}

TEST(LandmarkDatabase, GatesFromTheEstimateAndReassociationKeepRevisitsFromDuplicating) {
  // With the pose held (true pose, small covariance), confirmed landmarks coming back are gated
  // by that covariance instead of the odometry drift since they were last seen, and those
  // missed are re-associated after the correction: fewer duplicates than with odometry gates on
  // the same drifting stream, at the same precision.
  const SyntheticStreamOptions so = driftingStream();
  constexpr int kFrames = 2000;
  const RunOutcome odometry = runSynthetic(so, LandmarkOptions(), kFrames);
  int reassociated = 0, reassociated_offset = 0;
  Localized held;
  held.reassociated = &reassociated;
  const RunOutcome localized = runSynthetic(so, LandmarkOptions(), kFrames, &held);
  // A prediction 3 cm off sideways every frame (beyond the estimate's gates, ~5 px at 3 m): the
  // first pass misses, the second pass with the corrected pose finds them.
  Localized off = held;
  off.prediction_offset_m = 0.03;
  off.reassociated = &reassociated_offset;
  const RunOutcome offset = runSynthetic(so, LandmarkOptions(), kFrames, &off);
  std::printf(
      "duplicates: odometry gates %d of %d confirmed (%d correct); estimate gates %d of %d "
      "(%d correct, %d re-associated); prediction 3 cm off %d of %d (%d correct, %d "
      "re-associated)\n",
      odometry.duplicates,
      odometry.confirmed,
      odometry.correct,
      localized.duplicates,
      localized.confirmed,
      localized.correct,
      reassociated,
      offset.duplicates,
      offset.confirmed,
      offset.correct,
      reassociated_offset);
  ASSERT_GT(localized.confirmed, 100);
  ASSERT_GT(odometry.confirmed, 100);
  const auto fraction = [](const RunOutcome& o) {
    return static_cast<double>(o.duplicates) / std::max(1, o.confirmed);
  };
  // Measured (seed 20261129): 7.8 % with odometry gates, 2.9 % with the estimate's, 2.6 % with
  // the prediction 3 cm off (16048 re-associations).
  EXPECT_LT(fraction(localized), 0.5 * fraction(odometry));
  EXPECT_GE(static_cast<double>(localized.correct) / localized.confirmed, kMinPrecision);
  EXPECT_GT(reassociated_offset, 1000);
  EXPECT_LT(fraction(offset), 0.5 * fraction(odometry));
  EXPECT_GE(static_cast<double>(offset.correct) / std::max(1, offset.confirmed), kMinPrecision);
}

TEST(LandmarkDatabase, FusionKeepsOneLandmarkPerPoint) {
  // Fusion (TrackerOptions::fuse_radius_px): a corner that a confirmed landmark is predicted on
  // is that landmark's, even when its gate held other corners too, and a candidate confirmed
  // where a confirmed landmark already is, is that landmark. On the drifting stream, localised
  // with the prediction 3 cm off (the first pass misses, so candidates are seeded on landmarks'
  // corners), fusion must cut the duplicates without losing a point or precision.
  const SyntheticStreamOptions so = driftingStream();
  constexpr int kFrames = 1000;
  Localized off;
  off.prediction_offset_m = 0.03;
  LandmarkOptions without;
  without.tracker.fuse_radius_px = 0.0;
  LandmarkOptions with = without;
  with.tracker.fuse_radius_px = 1.5;
  const RunOutcome a = runSynthetic(so, without, kFrames, &off);
  const RunOutcome b = runSynthetic(so, with, kFrames, &off);
  std::printf(
      "fusion off: %d confirmed, %d duplicates, %d distinct correct; on: %d confirmed, %d "
      "duplicates, %d distinct correct (%d fused, %d reclaimed)\n",
      a.confirmed,
      a.duplicates,
      a.distinct_correct,
      b.confirmed,
      b.duplicates,
      b.distinct_correct,
      b.fused,
      b.reclaimed);
  ASSERT_GT(a.confirmed, 100);
  EXPECT_EQ(a.fused + a.reclaimed, 0);
  EXPECT_GT(b.fused + b.reclaimed, 0);
  EXPECT_LE(b.duplicates, a.duplicates);
  // Points kept: fusion drops only second landmarks of a point (kDistinctLossMax of noise).
  constexpr double kDistinctLossMax = 0.02;
  EXPECT_GE(b.distinct_correct, (1.0 - kDistinctLossMax) * a.distinct_correct);
  EXPECT_GE(static_cast<double>(b.correct) / std::max(1, b.confirmed), kMinPrecision);
}

TEST(LandmarkDatabase, ConfirmedCapBoundsMemoryUnderDrift) {
  SyntheticStreamOptions so;
  so.seed = 5;
  so.num_points = 1500;
  LandmarkOptions options;
  options.tracker.max_confirmed = 300;
  const StereoRig rig = SyntheticStream::defaultRig();
  SyntheticStream stream(rig, so);
  LandmarkDatabase db(rig, options);
  SyntheticFrame frame;
  FrameReport report;
  for (int k = 0; k < 1200; ++k) {
    stream.next(&frame);
    ASSERT_TRUE(
        db.update(frame.frame, frame.t_ns, frame.odom_pose, frame.hypotheses, &report).isOk());
    ASSERT_LE(db.numConfirmed(), options.tracker.max_confirmed);
  }
  EXPECT_EQ(db.numConfirmed(), options.tracker.max_confirmed);
}

/// A frame's frontend output holding one corner at the rounded pixel of `uvd` with the single
/// (complete) hypothesis d = uvd.z().
StereoHypotheses lonePoint(const Eigen::Vector3d& uvd) {
  StereoHypotheses hyps;
  SalientPoint sp;
  sp.corner.u_px = static_cast<int>(std::lround(uvd.x()));
  sp.corner.v_px = static_cast<int>(std::lround(uvd.y()));
  sp.num_hypotheses = 1;
  sp.complete = true;
  DisparityHypothesis h;
  h.d_px = static_cast<float>(uvd.z());
  hyps.points.push_back(sp);
  hyps.hypotheses.push_back(h);
  return hyps;
}

/// One point detected with its true disparity in every frame while the robot drives straight
/// ahead at 2 cm per frame. Returns the frame of its confirmation, -1 if it stays a candidate.
int confirmationFrame(const LandmarkOptions& options, const Eigen::Vector3d& p_w, int frames) {
  const StereoRig rig = SyntheticStream::defaultRig();
  LandmarkDatabase db(rig, options);
  FrameReport report;
  for (int k = 0; k < frames; ++k) {
    Pose2 pose;
    pose.x_m = 0.02 * k;
    const Eigen::Vector3d p_cl = cameraPoseInWorld(pose, rig.T_b_cl).inverse() * p_w;
    Eigen::Vector3d uvd;
    EXPECT_TRUE(projectStereo(rig, p_cl, &uvd));
    const Status s = db.update(k, 100'000'000LL * k, pose, lonePoint(uvd), &report);
    EXPECT_TRUE(s.isOk()) << s.message();
    if (report.confirmed > 0) return k;
  }
  return -1;
}

// Minimum parallax: a point straight ahead of a robot driving at it is seen from one bearing
// (its pixel only drifts by rounding), so its re-observations say little about its depth and
// it is not confirmed, however often it is seen; beside the path it is.
TEST(LandmarkDatabase, ConfirmationNeedsAMinimumParallax) {
  constexpr int kFrames = 40;  // 0.8 m of travel, 10 times what a lone point needs to confirm
  const StereoRig rig = SyntheticStream::defaultRig();
  // On the line the left camera's centre moves along, 4 m ahead of it.
  const Eigen::Vector3d ahead = rig.T_b_cl.translation() + Eigen::Vector3d(4.0, 0.0, 0.0);
  const Eigen::Vector3d beside = ahead + Eigen::Vector3d(0.0, 1.0, 0.0);
  const LandmarkOptions options;
  ASSERT_GT(options.consistency.min_parallax_deg, 0.0);
  EXPECT_EQ(confirmationFrame(options, ahead, kFrames), -1);
  const int beside_frame = confirmationFrame(options, beside, kFrames);
  EXPECT_GE(beside_frame, options.consistency.min_observations - 1);
  EXPECT_LT(beside_frame, 10) << "0.1 deg is reached after 2 frames";
  // Without the rule the point ahead is confirmed as soon as the one beside.
  LandmarkOptions any = options;
  any.consistency.min_parallax_deg = 0.0;
  EXPECT_EQ(confirmationFrame(any, ahead, kFrames), beside_frame);
  // A rule the point beside cannot meet within the run (3.3 deg after 0.8 m).
  LandmarkOptions strict = options;
  strict.consistency.min_parallax_deg = 5.0;
  EXPECT_EQ(confirmationFrame(strict, beside, kFrames), -1);
}

/// One wall point seen once, then never detected again while the robot drives towards it; each
/// later frame the database may re-measure it through `probe` (LandmarkOptions::probe_unseen).
struct ProbeRun {
  bool alive = false;
  int n_obs = 0;
  int probed = 0;
  int probe_found = 0;
};

/// `answers(d_true)` gives the disparities the probe reports at the point's predicted pixel.
ProbeRun runFlickeringPoint(const LandmarkOptions& options,
                            const std::function<std::vector<float>(float)>& answers,
                            bool with_probe,
                            int frames) {
  const StereoRig rig = SyntheticStream::defaultRig();
  LandmarkDatabase db(rig, options);
  const Eigen::Vector3d p_w(4.0, 0.3, 0.4);  // 4 m ahead, off the optical axis
  FrameReport report;
  ProbeRun run;
  for (int k = 0; k < frames; ++k) {
    Pose2 pose;
    pose.x_m = 0.02 * k;  // 2 cm per frame, straight ahead
    const Eigen::Vector3d p_cl = cameraPoseInWorld(pose, rig.T_b_cl).inverse() * p_w;
    Eigen::Vector3d uvd;
    EXPECT_TRUE(projectStereo(rig, p_cl, &uvd));
    const float d_true = static_cast<float>(uvd.z());
    const StereoHypotheses hyps = k == 0 ? lonePoint(uvd) : StereoHypotheses();
    // The pipeline's probe step, with a stand-in for Frontend::measureAt.
    Status s = db.beginFrame(k, 100'000'000LL * k, pose, hyps, &report);
    EXPECT_TRUE(s.isOk()) << s.message();
    if (with_probe) {
      StereoHypotheses measured;
      for (const Corner& c : db.probeRequests()) {
        SalientPoint sp;
        sp.corner = c;
        sp.first_hypothesis = static_cast<uint32_t>(measured.hypotheses.size());
        for (float d : answers(d_true)) {
          DisparityHypothesis h;
          h.d_px = d;
          h.point_index = static_cast<uint32_t>(measured.points.size());
          measured.hypotheses.push_back(h);
          ++sp.num_hypotheses;
        }
        measured.points.push_back(sp);
      }
      s = db.addProbeResults(measured);
      EXPECT_TRUE(s.isOk()) << s.message();
    }
    db.finishFrame();
    run.probed += report.probed;
    run.probe_found += report.probe_found;
  }
  for (const Landmark& l : db.landmarks()) {
    if (l.state == LandmarkState::kFree) continue;
    run.alive = true;
    run.n_obs = l.n_obs;
  }
  return run;
}

// A real corner the detector stops finding is still there at its predicted depth: the probe's
// one answer in the gate is neither a hit nor a miss, so the candidate lives on (without any
// evidence or observation from it), where each lost detection used to count as a miss.
TEST(LandmarkDatabase, ProbeFindingTheUnseenPointAtItsDepthIsNotAMiss) {
  constexpr int kFrames = 20;  // past max_consecutive_misses (8) and the prune probability
  const LandmarkOptions options;
  ASSERT_TRUE(options.consistency.probe_unseen);
  const auto truth = [](float d) { return std::vector<float>{d}; };
  const ProbeRun found = runFlickeringPoint(options, truth, true, kFrames);
  EXPECT_TRUE(found.alive);
  EXPECT_EQ(found.n_obs, 1) << "a probe's answer is not an observation";
  EXPECT_EQ(found.probed, kFrames - 1);
  EXPECT_EQ(found.probe_found, kFrames - 1);
  // Without the probe, or with the option off, the misses prune it.
  EXPECT_FALSE(runFlickeringPoint(options, truth, false, kFrames).alive);
  LandmarkOptions off = options;
  off.consistency.probe_unseen = false;
  const ProbeRun unused = runFlickeringPoint(off, truth, true, kFrames);
  EXPECT_FALSE(unused.alive);
  EXPECT_EQ(unused.probed, 0);
  // An answer outside the gate (another depth), or several answers (ambiguous), is still a miss.
  constexpr float kOtherDepthPx = 6.0f;
  const ProbeRun elsewhere = runFlickeringPoint(
      options, [](float d) { return std::vector<float>{d + kOtherDepthPx}; }, true, kFrames);
  EXPECT_FALSE(elsewhere.alive);
  EXPECT_GT(elsewhere.probed, 0);
  EXPECT_EQ(elsewhere.probe_found, 0);
  const ProbeRun not_finite = runFlickeringPoint(
      options,
      [](float) { return std::vector<float>{std::numeric_limits<float>::quiet_NaN()}; },
      true,
      kFrames);
  EXPECT_FALSE(not_finite.alive);
  EXPECT_EQ(not_finite.probe_found, 0);
  const ProbeRun ambiguous = runFlickeringPoint(
      options,
      [](float d) {
        return std::vector<float>{d, d + kOtherDepthPx};
      },
      true,
      kFrames);
  EXPECT_FALSE(ambiguous.alive);
  EXPECT_EQ(ambiguous.probe_found, 0);
  // The baselines, as published, do not re-measure.
  LandmarkOptions seen = options;
  seen.policy = Policy::kSeenCount;
  EXPECT_EQ(runFlickeringPoint(seen, truth, true, kFrames).probed, 0);
}

TEST(LandmarkDatabase, ProbeResultAtAPixelNotAskedForIsAnErrorThatMarksNothing) {
  AfterFirstFrame first;
  ASSERT_TRUE(first.status.isOk()) << first.status.message();
  LandmarkDatabase& db = first.db;
  const SyntheticFrame& frame = first.frame;
  FrameReport& report = first.report;
  // Nothing detected in the next frame: every candidate is unassociated, so all are requested.
  ASSERT_TRUE(
      db.beginFrame(1, frame.t_ns + 1, frame.odom_pose, StereoHypotheses(), &report).isOk());
  const std::vector<Corner> requests = db.probeRequests();
  ASSERT_FALSE(requests.empty());
  EXPECT_EQ(report.probed, static_cast<int>(requests.size()));
  StereoHypotheses measured;
  SalientPoint stray;
  stray.corner.u_px = requests[0].u_px + 1;  // beside the requested pixel
  stray.corner.v_px = requests[0].v_px;
  measured.points.push_back(stray);
  const Status s = db.addProbeResults(measured);
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("re-measuring unseen candidates: the probe returned a pixel"),
            std::string::npos)
      << s.message();
  EXPECT_EQ(report.probe_found, 0);
}

TEST(LandmarkDatabase, ReportsIdsThatFindLooksUp) {
  AfterFirstFrame first;
  ASSERT_TRUE(first.status.isOk()) << first.status.message();
  const LandmarkDatabase& db = first.db;
  const FrameReport& report = first.report;
  ASSERT_FALSE(report.created_ids.empty());
  ASSERT_EQ(report.created_ids.size(), report.created_hypotheses.size());
  for (size_t i = 0; i < report.created_ids.size(); ++i) {
    const Landmark* l = db.find(report.created_ids[i]);
    ASSERT_NE(l, nullptr);
    EXPECT_EQ(l->id, report.created_ids[i]);
    EXPECT_EQ(report.hypothesis_landmark_id[report.created_hypotheses[i]], l->id);
  }
  ASSERT_EQ(report.hypothesis_landmark_id.size(), first.frame.hypotheses.hypotheses.size());
  for (uint64_t id : report.hypothesis_landmark_id) {
    if (id != 0) {
      EXPECT_NE(db.find(id), nullptr);
    }
  }
  EXPECT_EQ(db.find(0), nullptr);
  for (uint64_t id : report.removed_ids) EXPECT_EQ(db.find(id), nullptr);
}

TEST(LandmarkDatabase, ConfirmedLandmarkReclaimsItsCornerFromAnAmbiguousGate) {
  // A confirmed landmark whose gate holds two corners is not associated by the gate; the corner
  // exactly at its prediction (well inside the 2 px Harris spacing) is still its own, so it is
  // taken by the landmark instead of being seeded as a new candidate. Without fusion it is seeded.
  for (const double radius : {0.0, 1.5}) {
    SCOPED_TRACE(radius);
    LandmarkOptions options;
    options.tracker.fuse_radius_px = radius;
    options.consistency.stability_evidence = 5.0;  // confirm the first landmark quickly
    const StereoRig rig = SyntheticStream::defaultRig();
    LandmarkDatabase db(rig, options);
    const Eigen::Vector3d uvd(320.0, 240.0, 20.0);
    FrameReport report;
    Pose2 pose;
    int32_t frame = 0;
    uint64_t id = 0;
    // The same world point each frame, projected from that frame's pose.
    const Eigen::Vector3d p_w =
        cameraPoseInWorld(Pose2{}, rig.T_b_cl) * *triangulateRectified(rig, uvd.head<2>(), uvd.z());
    for (; frame < 40 && db.numConfirmed() == 0; ++frame) {
      pose.x_m = 0.02 * frame;
      const Eigen::Isometry3d T_w_cl = cameraPoseInWorld(pose, rig.T_b_cl);
      Eigen::Vector3d uvd_k;
      ASSERT_TRUE(projectStereo(rig, T_w_cl.inverse() * p_w, &uvd_k));
      ASSERT_TRUE(db.update(frame, frame * 66'666'667LL, pose, lonePoint(uvd_k), &report).isOk());
    }
    ASSERT_EQ(db.numConfirmed(), 1) << "the lone point was not confirmed";
    for (const Landmark& l : db.landmarks()) {
      if (l.state == LandmarkState::kConfirmed) id = l.id;
    }
    const Landmark* l = db.find(id);
    ASSERT_NE(l, nullptr);
    pose.x_m = 0.02 * frame;
    Eigen::Vector3d pred;
    ASSERT_TRUE(projectStereo(rig, cameraPoseInWorld(pose, rig.T_b_cl).inverse() * l->p_w, &pred));
    // Two corners in the gate: one at the prediction, one 3 px to the side.
    StereoHypotheses hyps = lonePoint(pred);
    StereoHypotheses other = lonePoint(pred + Eigen::Vector3d(3.0, 0.0, 0.0));
    other.points[0].first_hypothesis = 1;
    other.hypotheses[0].point_index = 1;
    hyps.points.push_back(other.points[0]);
    hyps.hypotheses.push_back(other.hypotheses[0]);
    ASSERT_TRUE(db.update(frame, frame * 66'666'667LL, pose, hyps, &report).isOk());
    if (radius > 0.0) {
      EXPECT_EQ(report.reclaimed, 1);
      EXPECT_EQ(report.hypothesis_landmark_id[0], id);
      EXPECT_EQ(db.find(id)->last_seen_frame, frame);
    } else {
      EXPECT_EQ(report.reclaimed, 0);
      EXPECT_NE(report.hypothesis_landmark_id[0], id);
      EXPECT_NE(report.hypothesis_landmark_id[0], 0u) << "the corner should have been seeded";
    }
  }
}

TEST(LandmarkDatabase, RestoredLandmarksAreConfirmedAndReassociated) {
  // A saved map's landmark handed back between frames (restoreConfirmed) is confirmed at once
  // and takes its corner in the next frame instead of a new candidate being seeded there.
  const StereoRig rig = SyntheticStream::defaultRig();
  LandmarkDatabase db(rig, LandmarkOptions());
  FrameReport report;
  Pose2 pose;
  ASSERT_TRUE(db.update(0, 0, pose, StereoHypotheses(), &report).isOk());
  const Eigen::Vector3d uvd(300.0, 200.0, 25.0);
  const Eigen::Vector3d p_w =
      cameraPoseInWorld(pose, rig.T_b_cl) * *triangulateRectified(rig, uvd.head<2>(), uvd.z());
  std::vector<uint64_t> ids;
  db.restoreConfirmed({p_w, Eigen::Vector3d(std::nan(""), 0.0, 0.0)}, &ids);
  ASSERT_EQ(ids.size(), 1u) << "a non-finite position is skipped";
  EXPECT_EQ(db.numConfirmed(), 1);
  ASSERT_NE(db.find(ids[0]), nullptr);
  EXPECT_EQ(db.find(ids[0])->state, LandmarkState::kConfirmed);
  pose.x_m = 0.02;
  Eigen::Vector3d next;
  ASSERT_TRUE(projectStereo(rig, cameraPoseInWorld(pose, rig.T_b_cl).inverse() * p_w, &next));
  ASSERT_TRUE(db.update(1, 66'666'667, pose, lonePoint(next), &report).isOk());
  EXPECT_EQ(report.hypothesis_landmark_id[0], ids[0]);
  EXPECT_EQ(report.seeded, 0);
  EXPECT_EQ(db.find(ids[0])->last_seen_frame, 1);
}

TEST(LandmarkDatabase, ListsTheEarlierMapsUnassociatedLandmarksInView) {
  // The pipeline's re-anchoring reference: confirmed landmarks predicted in view, not associated
  // this frame, last seen before a given frame; the most observed, in id order.
  const StereoRig rig = SyntheticStream::defaultRig();
  LandmarkDatabase db(rig, LandmarkOptions());
  FrameReport report;
  Pose2 pose;
  ASSERT_TRUE(db.update(0, 0, pose, StereoHypotheses(), &report).isOk());
  const Eigen::Isometry3d T_w_cl = cameraPoseInWorld(pose, rig.T_b_cl);
  std::vector<Eigen::Vector3d> p_w;
  for (const double u : {100.0, 250.0, 400.0, 550.0}) {
    p_w.push_back(T_w_cl * *triangulateRectified(rig, Eigen::Vector2d(u, 200.0), 25.0));
  }
  p_w.push_back(T_w_cl * Eigen::Vector3d(0.0, 0.0, -2.0));  // behind the camera: not in view
  std::vector<uint64_t> ids;
  db.restoreConfirmed(p_w, &ids);
  ASSERT_EQ(ids.size(), 5u);
  // Frame 1 sees the second landmark only.
  Eigen::Vector3d seen;
  ASSERT_TRUE(projectStereo(rig, T_w_cl.inverse() * p_w[1], &seen));
  const StereoHypotheses hyps = lonePoint(seen);
  ASSERT_TRUE(db.beginFrame(1, 66'666'667, pose, hyps, &report).isOk());
  ASSERT_EQ(report.hypothesis_landmark_id[0], ids[1]);
  std::vector<uint64_t> listed{42};
  db.unassociatedConfirmedInView(1, 10, &listed);
  EXPECT_EQ(listed, (std::vector<uint64_t>{ids[0], ids[2], ids[3]})) << "replaced, id order";
  db.unassociatedConfirmedInView(1, 2, &listed);
  EXPECT_EQ(listed, (std::vector<uint64_t>{ids[0], ids[2]})) << "equal observations: lower ids";
  db.unassociatedConfirmedInView(0, 10, &listed);
  EXPECT_TRUE(listed.empty()) << "all were seen in frame 0";
  db.finishFrame();
}

TEST(LandmarkDatabase, PagedOutLandmarksLeaveWithoutBeingReportedRemoved) {
  // The working set (pipeline/working_set.h) pages confirmed landmarks out: they leave the
  // database, but no FrameReport lists them as removed (the map keeps them); candidates and
  // unknown ids are not paged. Handed back (restoreConfirmed) they are tracked again.
  const StereoRig rig = SyntheticStream::defaultRig();
  LandmarkDatabase db(rig, LandmarkOptions());
  FrameReport report;
  Pose2 pose;
  ASSERT_TRUE(db.update(0, 0, pose, StereoHypotheses(), &report).isOk());
  const Eigen::Vector3d uvd(300.0, 200.0, 25.0);
  const Eigen::Vector3d p_w =
      cameraPoseInWorld(pose, rig.T_b_cl) * *triangulateRectified(rig, uvd.head<2>(), uvd.z());
  std::vector<uint64_t> ids;
  db.restoreConfirmed({p_w, p_w + Eigen::Vector3d(0.0, 0.0, 0.3)}, &ids);
  ASSERT_EQ(ids.size(), 2u);
  // A candidate seeded from a corner elsewhere in the image.
  ASSERT_TRUE(
      db.update(1, 66'666'667, pose, lonePoint(Eigen::Vector3d(100.0, 100.0, 20.0)), &report)
          .isOk());
  ASSERT_EQ(db.numCandidates(), 1);
  const uint64_t candidate = report.created_ids.at(0);

  EXPECT_EQ(db.pageOut({ids[0], candidate, 999'999}), 1);
  EXPECT_EQ(db.find(ids[0]), nullptr);
  EXPECT_NE(db.find(candidate), nullptr) << "candidates are never paged";
  EXPECT_EQ(db.numConfirmed(), 1);
  EXPECT_EQ(db.pageOut({ids[0]}), 0) << "already out";
  ASSERT_TRUE(db.update(2, 133'333'333, pose, StereoHypotheses(), &report).isOk());
  EXPECT_TRUE(std::find(report.removed_ids.begin(), report.removed_ids.end(), ids[0]) ==
              report.removed_ids.end());

  // Back in: a new id, confirmed at once, associated with its corner in the next frame.
  std::vector<uint64_t> back;
  db.restoreConfirmed({p_w}, &back);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_NE(back[0], ids[0]);
  ASSERT_TRUE(db.update(3, 200'000'000, pose, lonePoint(uvd), &report).isOk());
  EXPECT_EQ(report.hypothesis_landmark_id[0], back[0]);
  EXPECT_EQ(db.numConfirmed(), 2);
}

}  // namespace
}  // namespace twocam::landmarks
