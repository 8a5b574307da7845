#include "landmarks/landmark_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "support/synthetic_stream.h"

namespace twocam::landmarks {
namespace {

using test::SyntheticStream;

TEST(LandmarkModel, RivalProbabilitiesSumToAtMostOne) {
  const double prior[3] = {0.2, 0.2, 0.1};
  const double evidence[3] = {3.0, -2.0, 800.0};  // huge evidence must not overflow
  double p[3];
  normaliseRivals(prior, evidence, 3, 0.5, 0.0, p);
  EXPECT_NEAR(p[0] + p[1] + p[2], 1.0, 1e-9);
  EXPECT_GT(p[2], 0.999);
  const double flat[2] = {0.0, 0.0};
  normaliseRivals(prior, flat, 2, 0.6, 0.0, p);
  EXPECT_NEAR(p[0], 0.2, 1e-12);  // no evidence: the prior
}

TEST(LandmarkModel, GateGrowsWithDistanceAndTurn) {
  const StereoRig rig = SyntheticStream::defaultRig();
  const LandmarkOptions options;
  const Eigen::Vector3d uvd(400.0, 300.0, 20.0);
  const MeasurementSigma s0 = predictionSigma(options.tracker, rig, uvd, 3.0, 0.0, 0.0);
  const MeasurementSigma s1 = predictionSigma(options.tracker, rig, uvd, 3.0, 1.0, 0.0);
  const MeasurementSigma s2 = predictionSigma(options.tracker, rig, uvd, 3.0, 1.0, 0.5);
  EXPECT_DOUBLE_EQ(s0.u_px, options.tracker.pixel_sigma_px);
  EXPECT_GT(s1.u_px, s0.u_px);
  EXPECT_GT(s1.d_px, s0.d_px);
  EXPECT_GT(s2.u_px, s1.u_px);
}

// A periodic-texture alias near the horizon under straight forward motion (the repetitive
// world's wrongly confirmed landmarks before the column check): the corner is a real point at
// 4.4 m, the alias disparity a fixed fraction of the real one. Its row hardly moves and its
// disparity grows by less than a pixel, so row and disparity alone cannot tell it from a real
// point 10 m away; its column moves away from the principal point like the real point's, not
// like the alias depth predicts.
TEST(LandmarkModel, AnchorCheckColumnsExposeAHorizonAliasUnderForwardMotion) {
  const StereoRig rig = SyntheticStream::defaultRig();
  const Eigen::Isometry3d T_w_cl_anchor = cameraPoseInWorld(Pose2{0.0, 0.0, 0.0}, rig.T_b_cl);
  const Eigen::Isometry3d T_cl_w = cameraPoseInWorld(Pose2{0.6, 0.0, 0.0}, rig.T_b_cl).inverse();
  const double fb = rig.fx_px * rig.baseline_m;
  const double u_a = 190.0;
  const double v_a =
      rig.cy_px - rig.fy_px * std::tan(5.0 * M_PI / 180.0) + 2.0;  // near the horizon
  const double d_true = fb / 4.4;
  const double d_alias = 0.44 * d_true;
  const auto p_cla = triangulateRectified(rig, Eigen::Vector2d(u_a, v_a), d_true);
  ASSERT_TRUE(p_cla.has_value());
  Eigen::Vector3d seen;
  ASSERT_TRUE(projectStereo(rig, T_cl_w * (T_w_cl_anchor * *p_cla), &seen));
  const double d_alias_seen = d_alias * seen.z() / d_true;
  constexpr double kPathM = 0.6;
  for (const bool columns : {false, true}) {
    LandmarkOptions options;
    options.consistency.anchor_check_columns = columns;
    const AnchorCheck real = checkAgainstAnchor(options,
                                                rig,
                                                T_w_cl_anchor,
                                                u_a,
                                                v_a,
                                                d_true,
                                                T_cl_w,
                                                seen.x(),
                                                seen.y(),
                                                seen.z(),
                                                kPathM,
                                                0.0);
    const AnchorCheck alias = checkAgainstAnchor(options,
                                                 rig,
                                                 T_w_cl_anchor,
                                                 u_a,
                                                 v_a,
                                                 d_alias,
                                                 T_cl_w,
                                                 seen.x(),
                                                 seen.y(),
                                                 d_alias_seen,
                                                 kPathM,
                                                 0.0);
    ASSERT_TRUE(real.valid && alias.valid);
    EXPECT_LT(real.mahalanobis2, 0.01)
        << "columns " << columns;  // exact observation of a real point
    if (columns) {
      EXPECT_GT(alias.mahalanobis2, 2.0 * options.consistency.anchor_gate_chi2);
    } else {
      EXPECT_LT(alias.mahalanobis2,
                options.consistency.anchor_gate_chi2);  // what the row/disparity check misses
    }
  }
  // A 25 px column error contradicts a real point after straight driving; after a turn the
  // heading error makes columns uninformative and the same error is within the gate.
  LandmarkOptions options;
  const AnchorCheck straight = checkAgainstAnchor(options,
                                                  rig,
                                                  T_w_cl_anchor,
                                                  u_a,
                                                  v_a,
                                                  d_true,
                                                  T_cl_w,
                                                  seen.x() + 25.0,
                                                  seen.y(),
                                                  seen.z(),
                                                  kPathM,
                                                  0.0);
  const AnchorCheck turned = checkAgainstAnchor(options,
                                                rig,
                                                T_w_cl_anchor,
                                                u_a,
                                                v_a,
                                                d_true,
                                                T_cl_w,
                                                seen.x() + 25.0,
                                                seen.y(),
                                                seen.z(),
                                                kPathM,
                                                1.5);
  ASSERT_TRUE(straight.valid && turned.valid);
  EXPECT_GT(straight.mahalanobis2, options.consistency.anchor_gate_chi2);
  EXPECT_LT(turned.mahalanobis2, options.consistency.anchor_gate_chi2);
}

// Verification sums the evidence of every consistent re-observation against the two periodic
// phantoms (docs/landmarks.md, "Verification"). Driving straight towards a real point 4 m away,
// a candidate at its true depth gathers evidence for itself against both phantoms and is
// verified well before one frame's motion alone would separate them by verify_chi2 (the rule
// until 2026-12-02); a candidate that is the phantom of a real point at another depth gathers
// evidence against itself and never gets there.
TEST(LandmarkModel, PhantomEvidenceVerifiesARealPointAndNotAPhantom) {
  const StereoRig rig = SyntheticStream::defaultRig();
  const LandmarkOptions options;
  const Eigen::Isometry3d T_w_cl_anchor = cameraPoseInWorld(Pose2{0.0, 0.0, 0.0}, rig.T_b_cl);
  const double fb = rig.fx_px * rig.baseline_m;
  const double u_a = 420.0;
  const double v_a = 300.0;
  const double d_real = fb / 4.0;
  // A candidate that is a phantom: its anchor disparity is the real one's times a fixed ratio,
  // the real point sitting on the anchor ray at the lower phantom disparity of the test.
  const double offset = std::max(options.consistency.verify_min_offset_px,
                                 options.consistency.verify_relative_offset * d_real);
  const double d_phantom = d_real * d_real / (d_real - offset);
  const auto p_real = triangulateRectified(rig, Eigen::Vector2d(u_a, v_a), d_real);
  ASSERT_TRUE(p_real.has_value());
  constexpr double kStepM = 0.027;  // one frame at 0.4 m/s and 15 Hz
  double llr_real[2] = {0.0, 0.0};
  double llr_phantom[2] = {0.0, 0.0};
  int verified_frame = -1;
  int discriminative_frame = -1;
  for (int k = 1; k <= 30; ++k) {
    const double path_m = k * kStepM;
    const Eigen::Isometry3d T_cl_w =
        cameraPoseInWorld(Pose2{path_m, 0.0, 0.0}, rig.T_b_cl).inverse();
    Eigen::Vector3d seen;
    ASSERT_TRUE(projectStereo(rig, T_cl_w * (T_w_cl_anchor * *p_real), &seen));
    const AnchorCheck real = checkAgainstAnchor(options,
                                                rig,
                                                T_w_cl_anchor,
                                                u_a,
                                                v_a,
                                                d_real,
                                                T_cl_w,
                                                seen.x(),
                                                seen.y(),
                                                seen.z(),
                                                path_m,
                                                0.0);
    const AnchorCheck phantom = checkAgainstAnchor(options,
                                                   rig,
                                                   T_w_cl_anchor,
                                                   u_a,
                                                   v_a,
                                                   d_phantom,
                                                   T_cl_w,
                                                   seen.x(),
                                                   seen.y(),
                                                   seen.z() * d_phantom / d_real,
                                                   path_m,
                                                   0.0);
    ASSERT_TRUE(real.valid && phantom.valid);
    EXPECT_LT(real.mahalanobis2, 0.01);
    if (phantom.mahalanobis2 <=
        options.consistency.anchor_gate_chi2) {  // a contradiction is not summed
      for (int i = 0; i < 2; ++i) llr_phantom[i] += phantom.phantom_llr[i];
    }
    for (int i = 0; i < 2; ++i) {
      EXPECT_GE(real.phantom_llr[i], 0.0)
          << "frame " << k;  // an exact observation favours the truth
      llr_real[i] += real.phantom_llr[i];
    }
    if (verified_frame < 0 && std::min(llr_real[0], llr_real[1]) >= options.consistency.verify_llr)
      verified_frame = k;
    if (discriminative_frame < 0 && real.discriminative) discriminative_frame = k;
  }
  std::printf(
      "real point verified at frame %d (one frame's motion separates at %d); phantom's evidence "
      "%.1f, %.1f\n",
      verified_frame,
      discriminative_frame,
      llr_phantom[0],
      llr_phantom[1]);
  ASSERT_GT(verified_frame, 0) << "evidence " << llr_real[0] << ", " << llr_real[1];
  EXPECT_GT(verified_frame, 1);  // one small step is not enough
  EXPECT_TRUE(discriminative_frame < 0 || verified_frame < discriminative_frame)
      << "verified at frame " << verified_frame << ", one frame's motion separates at "
      << discriminative_frame;
  // The phantom's own evidence favours the real point it is a phantom of.
  EXPECT_LT(llr_phantom[0], 0.0);
  EXPECT_LT(std::min(llr_phantom[0], llr_phantom[1]), options.consistency.verify_llr);
}

// Explicit phantom disparities replace the generic offsets in phantom_llr (not in
// discriminative); a side given none has no phantom to beat.
TEST(LandmarkModel, OwnPhantomDisparitiesReplaceTheGenericOffsets) {
  const StereoRig rig = SyntheticStream::defaultRig();
  const LandmarkOptions options;
  const Eigen::Isometry3d T_w_cl_anchor = cameraPoseInWorld(Pose2{0.0, 0.0, 0.0}, rig.T_b_cl);
  const double u_a = 420.0;
  const double v_a = 300.0;
  const double d_a = 20.0;
  const auto p = triangulateRectified(rig, Eigen::Vector2d(u_a, v_a), d_a);
  ASSERT_TRUE(p.has_value());
  const Eigen::Isometry3d T_cl_w = cameraPoseInWorld(Pose2{0.3, 0.0, 0.0}, rig.T_b_cl).inverse();
  Eigen::Vector3d seen;
  ASSERT_TRUE(projectStereo(rig, T_cl_w * (T_w_cl_anchor * *p), &seen));
  seen.z() += 0.2;  // a little noise, so no likelihood ratio is exactly symmetric
  const auto check = [&](const float* phantoms) {
    return checkAgainstAnchor(options,
                              rig,
                              T_w_cl_anchor,
                              u_a,
                              v_a,
                              d_a,
                              T_cl_w,
                              seen.x(),
                              seen.y(),
                              seen.z(),
                              0.3,
                              0.0,
                              phantoms);
  };
  const AnchorCheck generic = check(nullptr);
  const double offset = std::max(options.consistency.verify_min_offset_px,
                                 options.consistency.verify_relative_offset * d_a);
  const float same[2] = {static_cast<float>(d_a - offset), static_cast<float>(d_a + offset)};
  const AnchorCheck as_generic = check(same);
  for (int k = 0; k < 2; ++k) EXPECT_NEAR(as_generic.phantom_llr[k], generic.phantom_llr[k], 1e-6);
  const float one_far_rival[2] = {0.0f, 40.0f};
  const AnchorCheck own = check(one_far_rival);
  EXPECT_EQ(own.phantom_llr[0], kPhantomImpossible);      // no rival below
  EXPECT_GT(own.phantom_llr[1], generic.phantom_llr[1]);  // a farther phantom is told apart sooner
  EXPECT_EQ(own.discriminative, generic.discriminative);  // still the generic offsets
  EXPECT_EQ(own.mahalanobis2, generic.mahalanobis2);
}

TEST(LandmarkModel, SvoSeedConvergesOnInliersAndDoubtsOutliers) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::uniform_real_distribution<double> uniform(0.0, 5.0);
  SvoSeed good{0.4, 25.0 / 36.0, 10.0, 10.0, 5.0};
  SvoSeed bad = good;
  for (int k = 0; k < 30; ++k) {
    updateSvoSeed(0.5 + noise(rng), 0.005 * 0.005, &good);
    updateSvoSeed(uniform(rng), 0.005 * 0.005, &bad);
  }
  EXPECT_NEAR(good.mu, 0.5, 0.01);
  // From Beta(10, 10) (ratio 0.5), 30 inliers lift the ratio to about 0.8 and 30 uniform
  // outliers push it to about 0.3.
  EXPECT_GT(good.a / (good.a + good.b), 0.75);
  EXPECT_LT(bad.a / (bad.a + bad.b), 0.4);
}

}  // namespace
}  // namespace twocam::landmarks
