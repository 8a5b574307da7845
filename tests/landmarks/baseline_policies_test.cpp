#include "landmarks/baseline_policies.h"

#include <gtest/gtest.h>

#include "landmarks/landmark_model.h"
#include "support/synthetic_stream.h"

namespace twocam::landmarks {
namespace {

using Decision = ConfirmationPolicy::Decision;

TEST(ConfirmationPolicy, FactoryPicksThePolicyOfTheOptions) {
  const StereoRig rig = test::SyntheticStream::defaultRig();
  LandmarkOptions options;
  EXPECT_NE(dynamic_cast<WtaLrcPolicy*>(makeConfirmationPolicy(rig,
                                                               [&] {
                                                                 options.policy = Policy::kWtaLrc;
                                                                 return options;
                                                               }())
                                            .get()),
            nullptr);
  options.policy = Policy::kSeenCount;
  EXPECT_NE(dynamic_cast<SeenCountPolicy*>(makeConfirmationPolicy(rig, options).get()), nullptr);
  options.policy = Policy::kCulling;
  EXPECT_NE(dynamic_cast<CullingPolicy*>(makeConfirmationPolicy(rig, options).get()), nullptr);
  options.policy = Policy::kInlierRatio;
  EXPECT_NE(dynamic_cast<InlierRatioPolicy*>(makeConfirmationPolicy(rig, options).get()), nullptr);
}

TEST(WtaLrcPolicy, SeedsOnlyLeftRightConsistentBestMatchesAndConfirmsThemAtOnce) {
  WtaLrcPolicy policy;
  DisparityHypothesis h;
  h.rank = 0;
  h.lr_consistent = true;
  EXPECT_TRUE(policy.seeds(h));
  h.lr_consistent = false;
  EXPECT_FALSE(policy.seeds(h));
  h.lr_consistent = true;
  h.rank = 1;
  EXPECT_FALSE(policy.seeds(h));
  EXPECT_TRUE(policy.confirmsAtSeed());
  EXPECT_FALSE(policy.probesUnseen());
  // Its confidence is the seed share of kBaselineSeedPrior.
  Landmark l;
  SeedInfo info;
  info.weight = 2.0;
  info.weight_sum = 2.0;
  policy.onSeed(0, &l, info, FrameContext());
  EXPECT_FLOAT_EQ(l.confidence, static_cast<float>(kBaselineSeedPrior));
}

TEST(SeenCountPolicy, ConfirmsWithinTheWindowAndPrunesAfterIt) {
  SeenCountOptions options;  // 2 observations within 4 s
  SeenCountPolicy policy(options);
  Landmark l;
  l.state = LandmarkState::kCandidate;
  l.first_t_ns = 0;
  l.n_obs = 1;
  FrameContext f;
  f.t_ns = 1'000'000'000;
  EXPECT_EQ(policy.decide(0, &l, f), Decision::kKeep);
  EXPECT_FLOAT_EQ(l.confidence, 0.5f);
  f.t_ns = 5'000'000'000;  // past the window, still once
  EXPECT_EQ(policy.decide(0, &l, f), Decision::kPrune);
  l.n_obs = 2;
  f.t_ns = 3'000'000'000;
  EXPECT_EQ(policy.decide(0, &l, f), Decision::kConfirm);
  EXPECT_FLOAT_EQ(l.confidence, 1.0f);
}

TEST(CullingPolicy, DecidesAfterTheDecisionFramesOnTheFoundRatio) {
  CullingOptions options;  // found/visible >= 0.25, >= 3 observations, after 3 frames
  CullingPolicy policy(options);
  Landmark l;
  l.first_frame = 10;
  l.n_obs = 3;
  l.n_visible = 4;
  FrameContext f;
  f.frame = 12;
  EXPECT_EQ(policy.decide(0, &l, f), Decision::kKeep);
  EXPECT_FLOAT_EQ(l.confidence, 0.75f);
  f.frame = 13;
  EXPECT_EQ(policy.decide(0, &l, f), Decision::kConfirm);
  l.n_visible = 20;  // found in 3 of 20 frames: 0.15
  EXPECT_EQ(policy.decide(0, &l, f), Decision::kPrune);
  l.n_visible = 4;
  l.n_obs = 2;
  l.n_visible = 2;  // ratio 1 but too few observations
  EXPECT_EQ(policy.decide(0, &l, f), Decision::kPrune);
}

TEST(InlierRatioPolicy, ConsistentDepthsConvergeAndRaiseTheInlierRatio) {
  const StereoRig rig = test::SyntheticStream::defaultRig();
  LandmarkOptions options;
  options.policy = Policy::kInlierRatio;
  InlierRatioPolicy policy(rig, options);
  policy.onAllocate(0);
  const Eigen::Vector3d p_w(3.0, 0.2, 0.5);
  Landmark l;
  l.state = LandmarkState::kCandidate;
  l.anchor.odom_pose = Pose2{};
  const Eigen::Vector3d p_cl0 = cameraPoseInWorld(l.anchor.odom_pose, rig.T_b_cl).inverse() * p_w;
  SeedInfo info;
  info.z_cl_m = p_cl0.z();
  policy.onSeed(0, &l, info, FrameContext());
  EXPECT_FLOAT_EQ(policy.state(0).range, static_cast<float>(1.0 / options.tracker.min_depth_m));
  const float ratio0 = policy.state(0).a / (policy.state(0).a + policy.state(0).b);
  EXPECT_EQ(policy.decide(0, &l, FrameContext()), Decision::kKeep);
  for (int k = 1; k <= 40; ++k) {
    const Pose2 pose{0.02 * k, 0.0, 0.0};
    l.p_w_last = p_w;  // the same point measured again
    policy.onMeasured(0, l, cameraPoseInWorld(pose, rig.T_b_cl).inverse() * p_w);
  }
  const InlierRatioPolicy::State& st = policy.state(0);
  EXPECT_GT(st.a / (st.a + st.b), ratio0);
  EXPECT_NEAR(st.mu, 1.0 / p_cl0.z(), 1e-3);
  EXPECT_EQ(policy.decide(0, &l, FrameContext()), Decision::kConfirm);
}

}  // namespace
}  // namespace twocam::landmarks
