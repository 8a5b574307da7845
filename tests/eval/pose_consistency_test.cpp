#include "eval/pose_consistency.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "landmarks/landmark_model.h"

namespace twocam::eval {
namespace {

constexpr uint64_t kSeed = 20261203;
/// Noise-free observations fit their point to solver precision.
constexpr double kExactRmsPx = 1e-6;

/// A point 4 m ahead seen from n poses driving forward 0.3 m per frame and turning.
std::vector<PosedObservation> track(const StereoRig& rig, int n, double noise_px, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_px);
  const Eigen::Vector3d p_w(4.0, 0.3, 0.2);
  std::vector<PosedObservation> out;
  for (int i = 0; i < n; ++i) {
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.translation() = Eigen::Vector3d(0.3 * i, 0.0, 0.0);
    T_w_b.linear() = Eigen::AngleAxisd(0.02 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    PosedObservation o;
    o.T_w_cl_true = T_w_b * rig.T_b_cl;
    Eigen::Vector3d uvd;
    EXPECT_TRUE(landmarks::projectStereo(rig, o.T_w_cl_true.inverse() * p_w, &uvd));
    o.u_px = uvd.x() + noise(rng);
    o.v_px = uvd.y() + noise(rng);
    o.d_px = uvd.z() + noise(rng);
    out.push_back(o);
  }
  return out;
}

TEST(TruePoseConsistency, ARealPointFitsItsObservationsUnderTheTrueMotion) {
  const StereoRig rig;
  EXPECT_LT(trueTriangulationRmsPx(rig, track(rig, 6, 0.0, kSeed)), kExactRmsPx);
  // Half-pixel measurement noise: an RMS well under the 1 px of METRICS.md.
  const double rms = trueTriangulationRmsPx(rig, track(rig, 8, 0.3, kSeed));
  EXPECT_GT(rms, 0.0);
  EXPECT_LT(rms, kConsistentRmsPx);
  // One observation is too few to judge.
  EXPECT_TRUE(std::isnan(trueTriangulationRmsPx(rig, track(rig, 1, 0.0, kSeed))));
}

TEST(TruePoseConsistency, AWrongAssociationOrDisparityIsInconsistent) {
  const StereoRig rig;
  std::vector<PosedObservation> obs = track(rig, 6, 0.0, kSeed);
  obs[3].u_px += 8.0;  // a neighbouring corner taken for one frame
  EXPECT_GT(trueTriangulationRmsPx(rig, obs), kConsistentRmsPx);
  // A spurious match: every disparity 4 px too large (a point at the wrong depth that the
  // odometry explained) does not fit the true motion.
  std::vector<PosedObservation> spurious = track(rig, 6, 0.0, kSeed);
  for (PosedObservation& o : spurious) o.d_px += 4.0;
  EXPECT_GT(trueTriangulationRmsPx(rig, spurious), kConsistentRmsPx);
}

TEST(TruePoseConsistency, JudgesConfirmedLandmarksFromTheFramesObservations) {
  StereoRig rig;
  const std::vector<PosedObservation> real = track(rig, 4, 0.0, kSeed);
  TruePoseConsistency pc(rig);
  for (size_t i = 0; i < real.size(); ++i) {
    // One salient point with two hypotheses: the real one (landmark 7) and a rival (8) whose
    // disparity is 5 px off in every frame.
    StereoHypotheses hyps;
    SalientPoint sp;
    sp.corner.u_px = static_cast<int>(std::lround(real[i].u_px));
    sp.corner.v_px = static_cast<int>(std::lround(real[i].v_px));
    sp.first_hypothesis = 0;
    sp.num_hypotheses = 2;
    hyps.points.push_back(sp);
    DisparityHypothesis h;
    h.point_index = 0;
    h.d_px = static_cast<float>(real[i].d_px);
    hyps.hypotheses.push_back(h);
    h.d_px += 5.0f;
    hyps.hypotheses.push_back(h);
    landmarks::FrameReport report;
    report.frame = static_cast<int32_t>(i);
    report.hypothesis_landmark_id = {7, 8};
    const Eigen::Isometry3d T_w_b = real[i].T_w_cl_true * rig.T_b_cl.inverse();
    pc.addFrame(hyps, report, T_w_b);
  }
  std::vector<landmarks::Landmark> slots(3);
  slots[0].id = 7;
  slots[0].state = landmarks::LandmarkState::kConfirmed;
  slots[1].id = 8;
  slots[1].state = landmarks::LandmarkState::kConfirmed;
  slots[2].id = 9;  // confirmed but never observed here: not judged
  slots[2].state = landmarks::LandmarkState::kConfirmed;
  const PoseConsistencyMetrics m = pc.finish(slots);
  EXPECT_EQ(m.judged, 2);
  EXPECT_EQ(m.consistent, 1);  // corner pixels are rounded: the real one still fits within 1 px
  EXPECT_DOUBLE_EQ(m.fraction, 0.5);
}

}  // namespace
}  // namespace twocam::eval
