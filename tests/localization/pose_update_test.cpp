#include "localization/pose_update.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

#include "support/synthetic_stream.h"

namespace twocam::localization {
namespace {

using test::SyntheticStream;

/// Tolerances, named.
// Auto-diff against central differences, relative to max(1, |J|): the differences' rounding
// error on residuals of hundreds of pixels is about 1e-6; a wrong derivative is off by O(1).
constexpr double kJacobianTol = 1e-4;
constexpr double kPositionTolM = 0.01;  // pose recovered from 0.3 px noise and 10 % outliers
constexpr double kYawTolRad = 0.2 * M_PI / 180.0;
constexpr uint64_t kSeed = 20261203;
// One-block against per-observation layout (StereoCostLayout): the same minimisation summed in
// another order, so rounding only (1e-15 measured); 1 nm and 1 nrad leave room for other compilers.
constexpr double kLayoutPositionTolM = 1e-9;
constexpr double kLayoutAngleTolRad = 1e-9;
constexpr double kLayoutCovarianceRelTol = 1e-6;
// TinySolver against the per-observation Ceres problem: both stop when a step changes the cost by
// less than 1e-6 of it, so they agree to the stopping tolerance (measured 4e-5 m, 9e-6 rad, no
// inlier flag differing on these scenes).
constexpr double kSolverPositionTolM = 2e-4;
constexpr double kSolverAngleTolRad = 1e-4;
constexpr double kSolverCovarianceRelTol = 1e-3;
constexpr int kSolverInlierDifferences = 2;

Eigen::Isometry3d pose(double x, double y, double yaw) { return toIsometry(Pose2{x, y, yaw}); }

/// Landmarks spread in front of the robot at `T_w_b`, observed exactly (plus noise), and a
/// share of outliers at random pixels.
std::vector<LandmarkObservation> observe(const StereoRig& rig,
                                         const Eigen::Isometry3d& T_w_b,
                                         int n,
                                         double pixel_noise,
                                         double outlier_share,
                                         std::mt19937_64* rng) {
  std::uniform_real_distribution<double> x(-2.0, 2.0), y(-1.0, 1.0), z(1.5, 6.0), unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, pixel_noise);
  const Eigen::Isometry3d T_w_cl = T_w_b * rig.T_b_cl;
  std::vector<LandmarkObservation> out;
  while (static_cast<int>(out.size()) < n) {
    const Eigen::Vector3d p_cl(x(*rng), y(*rng), z(*rng));
    LandmarkObservation o;
    o.id = out.size() + 1;
    o.p_w = T_w_cl * p_cl;
    const double inv_z = 1.0 / p_cl.z();
    o.u_px = rig.cx_px + rig.fx_px * p_cl.x() * inv_z + noise(*rng);
    o.v_px = rig.cy_px + rig.fy_px * p_cl.y() * inv_z + noise(*rng);
    o.d_px = rig.fx_px * rig.baseline_m * inv_z + noise(*rng);
    if (o.u_px < 0 || o.u_px >= rig.width_px || o.v_px < 0 || o.v_px >= rig.height_px) continue;
    if (unit(*rng) < outlier_share) {
      o.u_px = unit(*rng) * rig.width_px;
      o.v_px = unit(*rng) * rig.height_px;
      o.d_px = 2.0 + unit(*rng) * 40.0;
    }
    out.push_back(o);
  }
  return out;
}

template <typename Functor, int kResiduals>
void expectJacobiansMatch(const Functor& f, const Eigen::Isometry3d& T) {
  Eigen::Quaterniond q(T.linear());
  Eigen::Vector3d t = T.translation();
  double* params[] = {q.coeffs().data(), t.data()};
  ceres::AutoDiffCostFunction<Functor, kResiduals, 4, 3> autodiff(new Functor(f));
  ceres::NumericDiffCostFunction<Functor, ceres::CENTRAL, kResiduals, 4, 3> numeric(new Functor(f));
  double r_a[kResiduals], r_n[kResiduals];
  double jq_a[kResiduals * 4], jt_a[kResiduals * 3], jq_n[kResiduals * 4], jt_n[kResiduals * 3];
  double* j_a[] = {jq_a, jt_a};
  double* j_n[] = {jq_n, jt_n};
  ASSERT_TRUE(autodiff.Evaluate(params, r_a, j_a));
  ASSERT_TRUE(numeric.Evaluate(params, r_n, j_n));
  for (int i = 0; i < kResiduals; ++i) EXPECT_NEAR(r_a[i], r_n[i], kJacobianTol);
  for (int i = 0; i < kResiduals * 4; ++i)
    EXPECT_NEAR(jq_a[i], jq_n[i], kJacobianTol * std::max(1.0, std::abs(jq_a[i]))) << i;
  for (int i = 0; i < kResiduals * 3; ++i)
    EXPECT_NEAR(jt_a[i], jt_n[i], kJacobianTol * std::max(1.0, std::abs(jt_a[i]))) << i;
}

TEST(PoseUpdate, AutoDiffJacobiansMatchNumericOnes) {
  const StereoRig rig = SyntheticStream::defaultRig();
  std::mt19937_64 rng(kSeed);
  const Eigen::Isometry3d T_true = pose(1.0, 0.5, 0.3);
  const auto obs = observe(rig, T_true, 5, 0.0, 0.0, &rng);
  PoseUpdateOptions o;
  Eigen::Isometry3d T = pose(1.03, 0.48, 0.32);
  T.linear() = T.linear() * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX()).matrix();
  for (const LandmarkObservation& ob : obs)
    expectJacobiansMatch<StereoResidual, 3>(StereoResidual(rig, ob, o), T);
  PoseWithCovariance prediction;
  prediction.T_w_b = T_true;
  prediction.cov = Eigen::Vector3d(1e-4, 2e-4, 1e-5).asDiagonal();
  expectJacobiansMatch<PriorResidual, 6>(PriorResidual(prediction, o), T);
}

TEST(PoseUpdate, AnalyticStereoJacobiansMatchAutoDiffAndNumericOnes) {
  // The solver's cost (stereoResidualWithJacobians) against auto-diff of StereoResidual, and
  // through the previous test auto-diff against central differences; at poses off the true one
  // in every rotation axis, with a quaternion as Ceres' manifold keeps it (unit norm).
  const StereoRig rig = SyntheticStream::defaultRig();
  std::mt19937_64 rng(kSeed + 1);
  std::uniform_real_distribution<double> angle(-0.3, 0.3);
  const Eigen::Isometry3d T_true = pose(1.0, 0.5, 0.3);
  const auto obs = observe(rig, T_true, 20, 0.3, 0.0, &rng);
  const PoseUpdateOptions o;
  constexpr double kAnalyticTol = 1e-9;  // same formula, rounding only (relative to max(1, |J|))
  for (int trial = 0; trial < 5; ++trial) {
    Eigen::Isometry3d T = T_true;
    T.linear() = T.linear() * Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitX()).matrix() *
                 Eigen::AngleAxisd(0.3 * angle(rng), Eigen::Vector3d::UnitY()).matrix() *
                 Eigen::AngleAxisd(0.3 * angle(rng), Eigen::Vector3d::UnitZ()).matrix();
    T.translation() += Eigen::Vector3d(0.05, -0.03, 0.02);
    Eigen::Quaterniond q(T.linear());
    Eigen::Vector3d t = T.translation();
    double* params[] = {q.coeffs().data(), t.data()};
    for (const LandmarkObservation& ob : obs) {
      const StereoResidual f(rig, ob, o);
      ceres::AutoDiffCostFunction<StereoResidual, 3, 4, 3> autodiff(new StereoResidual(f));
      double r_a[3], jq_a[12], jt_a[9], r[3], jq[12], jt[9];
      double* j_a[] = {jq_a, jt_a};
      const bool ok_a = autodiff.Evaluate(params, r_a, j_a);
      ASSERT_EQ(stereoResidualWithJacobians(f, q.coeffs().data(), t.data(), r, jq, jt), ok_a);
      if (!ok_a) continue;
      for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(r[i], r_a[i], kAnalyticTol * std::max(1.0, std::abs(r_a[i])));
      for (int i = 0; i < 12; ++i)
        EXPECT_NEAR(jq[i], jq_a[i], kAnalyticTol * std::max(1.0, std::abs(jq_a[i]))) << i;
      for (int i = 0; i < 9; ++i)
        EXPECT_NEAR(jt[i], jt_a[i], kAnalyticTol * std::max(1.0, std::abs(jt_a[i]))) << i;
    }
  }
}

TEST(PoseUpdate, TangentJacobiansMatchNumericOnes) {
  // The TinySolver's cost (stereoTangentResidual) against central differences in the six
  // tangent parameters, at tangent points from zero to 0.3 rad (the right Jacobian's closed form)
  // and below 1e-4 rad (its series), about a base pose turned in every axis.
  const StereoRig rig = SyntheticStream::defaultRig();
  std::mt19937_64 rng(kSeed + 5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const Eigen::Isometry3d T_true = pose(1.0, 0.5, 0.3);
  const auto obs = observe(rig, T_true, 20, 0.3, 0.0, &rng);
  const PoseUpdateOptions o;
  const StereoResidual common(rig, LandmarkObservation{}, o);
  Eigen::Isometry3d T_0 = T_true;
  T_0.linear() = T_0.linear() * Eigen::AngleAxisd(0.1, Eigen::Vector3d(1, 2, 3).normalized());
  constexpr double kStep = 1e-6;
  const double scales[] = {0.0, 1e-5, 0.05, 0.3};
  int compared = 0;
  for (double scale : scales) {
    for (int trial = 0; trial < 3; ++trial) {
      Eigen::Matrix<double, 6, 1> x;
      for (int i = 0; i < 3; ++i) x[i] = scale * unit(rng);
      for (int i = 3; i < 6; ++i) x[i] = 0.05 * unit(rng);
      const TangentPose at(T_0, x, common.R_cl_b);
      for (const LandmarkObservation& ob : obs) {
        const StereoResidual f(rig, ob, o);
        double r[3], J[18];
        if (!stereoTangentResidual(f, at, r, J)) continue;
        for (int c = 0; c < 6; ++c) {
          Eigen::Matrix<double, 6, 1> xp = x, xm = x;
          xp[c] += kStep;
          xm[c] -= kStep;
          double rp[3], rm[3];
          ASSERT_TRUE(stereoTangentResidual(f, TangentPose(T_0, xp, common.R_cl_b), rp, nullptr));
          ASSERT_TRUE(stereoTangentResidual(f, TangentPose(T_0, xm, common.R_cl_b), rm, nullptr));
          for (int i = 0; i < 3; ++i) {
            const double numeric = (rp[i] - rm[i]) / (2.0 * kStep);
            EXPECT_NEAR(J[i * 6 + c], numeric, kJacobianTol * std::max(1.0, std::abs(numeric)))
                << "scale " << scale << " row " << i << " column " << c;
          }
        }
        ++compared;
      }
    }
  }
  EXPECT_GE(compared, 200);
}

TEST(PoseUpdate, RecoversTheTruePoseFromAWrongPredictionDespiteOutliers) {
  const StereoRig rig = SyntheticStream::defaultRig();
  std::mt19937_64 rng(kSeed + 1);
  const Eigen::Isometry3d T_true = pose(2.0, -1.0, 0.7);
  const auto obs = observe(rig, T_true, 80, 0.3, 0.1, &rng);
  PoseWithCovariance prediction;
  // 6 cm and 2 degrees off, with a prior that says so (5 cm, 2 degrees): under the odometry's
  // own covariance (5 mm) the prior would outweigh the disparities' forward information (about
  // 2 cm from 72 points at 3 m): a slip is for the slip test to find.
  prediction.T_w_b = pose(2.05, -0.97, 0.7 + 2.0 * M_PI / 180.0);
  prediction.cov = Eigen::Vector3d(2.5e-3, 2.5e-3, 1.2e-3).asDiagonal();
  const PoseUpdateResult r = updatePose(rig, prediction, obs, PoseUpdateOptions{});
  ASSERT_TRUE(r.visual);
  const Pose2 est = toPose2(r.estimate.T_w_b);
  EXPECT_NEAR(est.x_m, 2.0, kPositionTolM);
  EXPECT_NEAR(est.y_m, -1.0, kPositionTolM);
  EXPECT_NEAR(est.yaw_rad, 0.7, kYawTolRad);
  EXPECT_GE(r.inliers, 60);  // 72 or so of the 80 are real; outliers are not counted
  EXPECT_LE(r.inliers, 80);
  // The visual covariance is far tighter than the prior's.
  EXPECT_LT(r.estimate.cov(0, 0), 0.5 * prediction.cov(0, 0));
  // The slip shows in the window test against odometry that reported the wrong motion.
  PoseWithCovariance start;
  start.T_w_b = pose(1.9, -1.0, 0.7);
  const Pose2 odo = odometryIncrement(toPose2(start.T_w_b), toPose2(prediction.T_w_b));
  const Eigen::Matrix3d odo_cov = odometryCovariance(OdometryNoise{}, 0.15, 0.035);
  EXPECT_GT(slipChi2(start, r.estimate, odo, odo_cov), SlipTestOptions{}.chi2);
}

/// What compareLayouts found over its scenes.
struct LayoutComparison {
  double worst_position_m = 0.0;
  double worst_angle_rad = 0.0;
  int visual = 0;              // scenes both solved visually
  int inlier_differences = 0;  // inlier flags that differ, over every scene
};

/// Solves the same 36 seeded scenes (12 to 400 observations, 0 to 30 % outliers, predictions
/// from exact to a slip's 8 cm and 3 degrees) with two layouts and expects the poses within the
/// tolerances and the covariances relatively within cov_rel_tol.
LayoutComparison compareLayouts(StereoCostLayout first,
                                StereoCostLayout second,
                                double position_tol_m,
                                double angle_tol_rad,
                                double cov_rel_tol) {
  const StereoRig rig = SyntheticStream::defaultRig();
  std::mt19937_64 rng(kSeed + 4);
  std::uniform_real_distribution<double> off(-1.0, 1.0);
  const int sizes[] = {12, 40, 150, 400};
  const double outlier_shares[] = {0.0, 0.1, 0.3};
  const double offsets[] = {0.0, 0.02, 0.08};  // prediction error [m]; yaw error offset * 40 deg
  LayoutComparison out;
  for (int n : sizes) {
    for (double share : outlier_shares) {
      for (double offset : offsets) {
        const Eigen::Isometry3d T_true = pose(off(rng), off(rng), M_PI * off(rng));
        const auto obs = observe(rig, T_true, n, 0.3, share, &rng);
        PoseWithCovariance prediction;
        prediction.T_w_b =
            T_true *
            pose(offset * off(rng), offset * off(rng), offset * 40.0 * M_PI / 180.0 * off(rng));
        prediction.cov = Eigen::Vector3d(2.5e-3, 2.5e-3, 1.2e-3).asDiagonal();
        const PoseUpdateOptions o;
        const PoseUpdateResult a = updatePose(rig, prediction, obs, o, first);
        const PoseUpdateResult b = updatePose(rig, prediction, obs, o, second);
        EXPECT_EQ(a.visual, b.visual) << n << " " << share << " " << offset;
        if (a.visual != b.visual) continue;
        out.visual += a.visual ? 1 : 0;
        for (size_t i = 0; i < a.inlier.size(); ++i)
          out.inlier_differences += a.inlier[i] != b.inlier[i];
        const double dt = (a.estimate.T_w_b.translation() - b.estimate.T_w_b.translation()).norm();
        const double da =
            Eigen::AngleAxisd(a.estimate.T_w_b.linear().transpose() * b.estimate.T_w_b.linear())
                .angle();
        out.worst_position_m = std::max(out.worst_position_m, dt);
        out.worst_angle_rad = std::max(out.worst_angle_rad, da);
        EXPECT_LT(dt, position_tol_m) << n << " " << share << " " << offset;
        EXPECT_LT(da, angle_tol_rad) << n << " " << share << " " << offset;
        EXPECT_TRUE(a.estimate.cov.isApprox(b.estimate.cov, cov_rel_tol))
            << n << " " << share << " " << offset;
      }
    }
  }
  return out;
}

/// Two layouts that run the same minimisation: they differ by rounding only, on nearly every
/// scene solved (the comparison is not vacuous) and with no inlier flag different.
void expectSameMinimisation(StereoCostLayout first, StereoCostLayout second, const char* what) {
  const LayoutComparison c = compareLayouts(
      first, second, kLayoutPositionTolM, kLayoutAngleTolRad, kLayoutCovarianceRelTol);
  EXPECT_GE(c.visual, 30);
  EXPECT_EQ(c.inlier_differences, 0);
  std::cout << what << ": worst position " << c.worst_position_m << " m, worst angle "
            << c.worst_angle_rad << " rad\n";
}

TEST(PoseUpdate, OneBlockLayoutSolvesAsThePerObservationBlocksDo) {
  // The one cost function with the loss applied inside (StereoCostLayout::kOneBlock) against one
  // Ceres residual block per observation with Ceres' own Huber, then Cauchy, loss.
  expectSameMinimisation(StereoCostLayout::kOneBlock,
                         StereoCostLayout::kPerObservation,
                         "one block vs per observation");
}

TEST(PoseUpdate, TinySolverFindsTheMinimumOfTheCeresProblem) {
  // TinySolver on the tangent parameters (StereoCostLayout::kTinySolver, which the default
  // kNormalEquations follows step for step) against the per-observation ceres::Problem. Two
  // Levenberg-Marquardt implementations stopping at a relative cost change of 1e-6, with priors
  // that differ at third order in the rotation change (a rotation vector against twice a
  // quaternion's vector part), so they agree to within the stopping tolerance.
  const LayoutComparison c = compareLayouts(StereoCostLayout::kTinySolver,
                                            StereoCostLayout::kPerObservation,
                                            kSolverPositionTolM,
                                            kSolverAngleTolRad,
                                            kSolverCovarianceRelTol);
  EXPECT_GE(c.visual, 30);
  EXPECT_LE(c.inlier_differences, kSolverInlierDifferences);
  std::cout << "TinySolver vs per-observation Problem: worst position " << c.worst_position_m
            << " m, worst angle " << c.worst_angle_rad << " rad, inlier flags differing "
            << c.inlier_differences << "\n";
}

TEST(PoseUpdate, NormalEquationsSolveStepsAsTinySolverDoes) {
  // The default solve (StereoCostLayout::kNormalEquations) runs TinySolver's Levenberg-Marquardt
  // step for step on normal equations summed per observation: the same iterates up to the
  // summation order.
  expectSameMinimisation(StereoCostLayout::kNormalEquations,
                         StereoCostLayout::kTinySolver,
                         "normal equations vs TinySolver");
}

TEST(PoseUpdate, AStepThatPutsALandmarkBehindTheCameraIsRejected) {
  // A wrong association 5 mm in front of the predicted camera, which stands 3 cm behind the true
  // pose: every step towards the truth puts that landmark behind the camera. The solver must
  // reject such steps (an infinite cost, not NaN) as Ceres rejects a failed evaluation: the pose
  // stays finite, the landmark stays in front of it, and TinySolver ends where ceres::Problem
  // does.
  const StereoRig rig = SyntheticStream::defaultRig();
  std::mt19937_64 rng(kSeed + 6);
  const Eigen::Isometry3d T_true = pose(1.0, 0.5, 0.3);
  auto obs = observe(rig, T_true, 80, 0.3, 0.0, &rng);
  PoseWithCovariance prediction;
  prediction.T_w_b = T_true * pose(-0.03, 0.0, 0.0);
  prediction.cov = Eigen::Vector3d(2.5e-3, 2.5e-3, 1.2e-3).asDiagonal();
  LandmarkObservation near;
  near.id = 999;
  near.p_w = prediction.T_w_b * rig.T_b_cl * Eigen::Vector3d(0.0, 0.0, 0.005);
  near.u_px = rig.cx_px;
  near.v_px = rig.cy_px;
  near.d_px = 30.0;
  obs.push_back(near);
  const PoseUpdateResult tiny =
      updatePose(rig, prediction, obs, PoseUpdateOptions{}, StereoCostLayout::kTinySolver);
  const PoseUpdateResult normal =
      updatePose(rig, prediction, obs, PoseUpdateOptions{}, StereoCostLayout::kNormalEquations);
  const PoseUpdateResult problem =
      updatePose(rig, prediction, obs, PoseUpdateOptions{}, StereoCostLayout::kOneBlock);
  for (const PoseUpdateResult* r : {&tiny, &normal, &problem}) {
    EXPECT_TRUE(r->estimate.T_w_b.matrix().allFinite());
    EXPECT_TRUE(r->estimate.cov.allFinite());
    EXPECT_GT(((r->estimate.T_w_b * rig.T_b_cl).inverse() * near.p_w).z(), 0.0);
  }
  EXPECT_LT((tiny.estimate.T_w_b.translation() - problem.estimate.T_w_b.translation()).norm(),
            kSolverPositionTolM);
  EXPECT_LT((tiny.estimate.T_w_b.translation() - normal.estimate.T_w_b.translation()).norm(),
            kLayoutPositionTolM);
}

TEST(PoseUpdate, TooFewLandmarksKeepThePrediction) {
  const StereoRig rig = SyntheticStream::defaultRig();
  std::mt19937_64 rng(kSeed + 2);
  const Eigen::Isometry3d T_true = pose(0.0, 0.0, 0.0);
  const auto obs = observe(rig, T_true, 4, 0.3, 0.0, &rng);
  PoseWithCovariance prediction;
  prediction.T_w_b = pose(0.02, 0.0, 0.0);
  prediction.cov = Eigen::Vector3d(1e-4, 1e-4, 1e-4).asDiagonal();
  const PoseUpdateResult r = updatePose(rig, prediction, obs, PoseUpdateOptions{});
  EXPECT_FALSE(r.visual);
  EXPECT_EQ(r.observations, 4);
  EXPECT_TRUE(r.estimate.T_w_b.isApprox(prediction.T_w_b));
  EXPECT_TRUE(r.estimate.cov.isApprox(prediction.cov));
}

TEST(PoseUpdate, OdometryPredictionComposesAndItsCovarianceGrows) {
  PoseWithCovariance p;
  p.T_w_b = pose(1.0, 0.0, M_PI / 2.0);
  const OdometryNoise noise;
  const PoseWithCovariance q = predictPose(p, Pose2{0.5, 0.0, 0.1}, noise);
  const Pose2 e = toPose2(q.T_w_b);
  EXPECT_NEAR(e.x_m, 1.0, 1e-12);  // driving 0.5 m along the body x axis, which points along +y
  EXPECT_NEAR(e.y_m, 0.5, 1e-12);
  EXPECT_NEAR(e.yaw_rad, M_PI / 2.0 + 0.1, 1e-12);
  const Eigen::Matrix3d Q = odometryCovariance(noise, 0.5, 0.1);
  EXPECT_NEAR(q.cov(0, 0), Q(1, 1), 1e-15);  // the body's y variance is the world's x variance
  EXPECT_NEAR(q.cov(2, 2), Q(2, 2), 1e-15);
  // A heading error from the first step moves the second step sideways: x variance grows.
  const PoseWithCovariance r = predictPose(q, Pose2{0.5, 0.0, 0.0}, noise);
  EXPECT_GT(r.cov(0, 0), q.cov(0, 0) + 0.25 * q.cov(2, 2) * 0.99);
}

TEST(PoseUpdate, SlipTestQuietForConsistentMotion) {
  PoseWithCovariance start, end;
  start.T_w_b = pose(0.0, 0.0, 0.2);
  end.T_w_b = start.T_w_b * pose(0.08, 0.001, 0.01);
  start.cov = end.cov = Eigen::Vector3d(1e-6, 1e-6, 1e-6).asDiagonal();
  const Eigen::Matrix3d odo_cov = odometryCovariance(OdometryNoise{}, 0.08, 0.01);
  EXPECT_LT(slipChi2(start, end, Pose2{0.08, 0.0, 0.01}, odo_cov), 3.0);
  // A 4 cm wheel spin in the same window is flagged.
  EXPECT_GT(slipChi2(start, end, Pose2{0.12, 0.0, 0.01}, odo_cov), SlipTestOptions{}.chi2);
}

TEST(PoseUpdateOptions, RangesAreChecked) {
  PoseUpdateOptions o;
  EXPECT_TRUE(o.validate("localization.").isOk());
  o.pixel_sigma_px = std::nan("");
  const Status s = o.validate("localization.");
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("localization.pixel_sigma_px"), std::string::npos);
  SlipTestOptions t;
  t.window_frames = 0;
  EXPECT_FALSE(t.validate().isOk());
}

}  // namespace
}  // namespace twocam::localization
