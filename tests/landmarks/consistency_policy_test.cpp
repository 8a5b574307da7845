#include "landmarks/consistency_policy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "support/synthetic_stream.h"

namespace twocam::landmarks {
namespace {

/// Two rival candidates of one corner (slots 0 and 1) seeded into a fresh policy at frame 0.
struct TwoRivals {
  StereoRig rig = test::SyntheticStream::defaultRig();
  LandmarkOptions options;
  std::unique_ptr<ConsistencyPolicy> policy;
  std::vector<Landmark> slots = std::vector<Landmark>(2);
  StereoHypotheses hyps;
  FrameContext frame;

  explicit TwoRivals(const LandmarkOptions& o = LandmarkOptions()) : options(o) {
    policy = std::make_unique<ConsistencyPolicy>(rig, options);
    SalientPoint point;
    point.num_hypotheses = 2;
    hyps.points.push_back(point);
    for (float d : {10.0f, 20.0f}) {
      DisparityHypothesis h;
      h.d_px = d;
      hyps.hypotheses.push_back(h);
    }
    policy->beginSeedGroup(2);
    for (uint32_t s = 0; s < 2; ++s) {
      policy->onAllocate(s);
      slots[s].state = LandmarkState::kCandidate;
      slots[s].n_obs = 1;
      SeedInfo info;
      info.point = &hyps.points[0];
      info.hypotheses = &hyps;
      info.h = &hyps.hypotheses[s];
      info.rivals = 2;
      info.weight = 1.0;
      info.weight_sum = 2.0;
      info.z_cl_m = 3.0;
      policy->onSeed(s, &slots[s], info, frame);
    }
  }

  /// One frame `path_m` along the path in which slot 0 is hit and slot 1 missed.
  void hitFirstMissSecond(double path_m) {
    frame.frame += 1;
    frame.path_m = path_m;
    policy->beginFrame(slots.size());
    std::vector<Prediction> predictions(2);
    for (uint32_t s = 0; s < 2; ++s) {
      predictions[s].slot = s;
      predictions[s].confirmed = false;
      predictions[s].p_false_hit_per_hyp = 0.01f;
    }
    const uint8_t associated[2] = {1, 0};
    const uint8_t none[2] = {0, 0};
    FrameOutcome outcome{&predictions, associated, none, none};
    policy->scoreFrame(outcome, frame, &slots);
  }
};

TEST(ConsistencyPolicy, RivalsShareThePriorAndTheEvidenceMovesItBetweenThem) {
  TwoRivals r;
  constexpr float kPriorShare = 0.25f;  // prior_real 0.5 split between two rivals of weight 1
  EXPECT_FLOAT_EQ(r.slots[0].confidence, kPriorShare);
  EXPECT_FLOAT_EQ(r.slots[1].confidence, kPriorShare);
  r.hitFirstMissSecond(0.1);
  EXPECT_GT(r.slots[0].confidence, kPriorShare);
  EXPECT_LT(r.slots[1].confidence, kPriorShare);
  EXPECT_LE(r.slots[0].confidence + r.slots[1].confidence, 1.0f);
  // No motion since the last counted evidence: nothing changes.
  const float before = r.slots[0].confidence;
  r.hitFirstMissSecond(0.1);
  EXPECT_EQ(r.slots[0].confidence, before);
}

TEST(ConsistencyPolicy, ConfirmingOneRetiresItsRivals) {
  TwoRivals r;
  std::vector<uint32_t> rivals;
  r.policy->rivalsToRetire(0, &rivals);
  ASSERT_EQ(rivals, std::vector<uint32_t>{1});
  r.policy->onRelease(1, r.slots[1]);
  r.policy->onConfirmed(0);
  EXPECT_EQ(r.policy->state(0).group, 0u);
  EXPECT_EQ(r.policy->state(1).group, 0u);
  r.policy->rivalsToRetire(0, &rivals);
  EXPECT_TRUE(rivals.empty());
}

TEST(ConsistencyPolicy, ALandmarkSeenInThousandsOfFramesKeepsAFiniteConfidence) {
  // Each counted hit adds up to max_hit_evidence (1.5 nats): after ~500 hits prior * e^E is
  // beyond a double's range and the confidence used to be inf / inf = NaN.
  TwoRivals r;
  r.policy->onRelease(1, r.slots[1]);
  r.policy->onConfirmed(0);
  r.slots[0].state = LandmarkState::kConfirmed;
  constexpr int kFrames = 3000;
  for (int k = 1; k <= kFrames; ++k) {
    r.frame.frame += 1;
    r.frame.path_m = 0.1 * k;
    r.policy->beginFrame(r.slots.size());
    std::vector<Prediction> predictions(1);
    predictions[0].slot = 0;
    predictions[0].confirmed = true;
    predictions[0].p_false_hit_per_hyp = 0.01f;
    const uint8_t associated[2] = {1, 0};
    const uint8_t none[2] = {0, 0};
    FrameOutcome outcome{&predictions, associated, none, none};
    r.policy->scoreFrame(outcome, r.frame, &r.slots);
    ASSERT_TRUE(std::isfinite(r.slots[0].confidence)) << "frame " << k;
  }
  EXPECT_GT(r.policy->state(0).evidence, 1000.0f);  // far beyond exp()'s range of a double
  EXPECT_FLOAT_EQ(r.slots[0].confidence, 1.0f);
}

TEST(ConsistencyPolicy, DecidesOnProbabilityObservationsAndVerification) {
  LandmarkOptions options;
  options.consistency.min_parallax_deg = 0.0;  // no anchor check in this test
  TwoRivals r(options);
  FrameContext frame;
  // Rivals must be verified before they are confirmed, however probable.
  r.slots[0].confidence = 0.95f;
  r.slots[0].n_obs = options.consistency.min_observations;
  EXPECT_EQ(r.policy->decide(0, &r.slots[0], frame), ConfirmationPolicy::Decision::kKeep);
  EXPECT_FALSE(r.policy->state(0).verified);
  // Improbable after counted evidence: pruned.
  r.hitFirstMissSecond(0.1);
  r.slots[1].confidence = 0.01f;
  EXPECT_EQ(r.policy->decide(1, &r.slots[1], frame), ConfirmationPolicy::Decision::kPrune);
}

TEST(ConsistencyPolicy, OptionsSwitchTheTrackerHooks) {
  LandmarkOptions options;
  const StereoRig rig = test::SyntheticStream::defaultRig();
  ConsistencyPolicy on(rig, options);
  EXPECT_TRUE(on.probesUnseen());
  EXPECT_TRUE(on.rejectsAmbiguousConfirmedHits());
  options.consistency.probe_unseen = false;
  options.consistency.unambiguous_confirmed_hits = false;
  ConsistencyPolicy off(rig, options);
  EXPECT_FALSE(off.probesUnseen());
  EXPECT_FALSE(off.rejectsAmbiguousConfirmedHits());
  // Row support: a span above max(0.5 px, 5 % of d) is not supported.
  DisparityHypothesis h;
  h.d_px = 20.0f;
  h.row_span_px = 0.9f;
  EXPECT_TRUE(on.rowSupported(h));
  h.row_span_px = 1.1f;
  EXPECT_FALSE(on.rowSupported(h));
  EXPECT_FALSE(on.acceptsProbeAnswer(h));
  // Hypotheses within same_answer_px of a chosen one are the same answer.
  StereoHypotheses hyps;
  hyps.hypotheses.resize(1);
  hyps.hypotheses[0].d_px = 20.0f;
  const uint32_t chosen[1] = {0};
  h.d_px = 20.6f;
  EXPECT_TRUE(on.sameAnswerAsChosen(hyps, chosen, 1, h));
  h.d_px = 22.0f;
  EXPECT_FALSE(on.sameAnswerAsChosen(hyps, chosen, 1, h));
}

}  // namespace
}  // namespace twocam::landmarks
