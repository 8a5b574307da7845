#include "landmarks/refine.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "landmarks/landmark_model.h"
#include "support/synthetic_stream.h"

namespace twocam::landmarks {
namespace {

using test::SyntheticStream;

TEST(Refine, RecoversPointFromNoisyViewsDespiteAnOutlier) {
  const StereoRig rig = SyntheticStream::defaultRig();
  const Eigen::Vector3d p_true(4.0, 0.5, 1.2);
  std::mt19937_64 rng(9);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<Observation> obs;
  for (int k = 0; k < 12; ++k) {
    Observation o;
    o.frame = k;
    o.odom_pose = {0.1 * k, 0.02 * k, 0.01 * k};
    const Eigen::Vector3d p_cl = cameraPoseInWorld(o.odom_pose, rig.T_b_cl).inverse() * p_true;
    Eigen::Vector3d uvd;
    ASSERT_TRUE(projectStereo(rig, p_cl, &uvd));
    o.u_px = static_cast<float>(uvd.x() + noise(rng));
    o.v_px = static_cast<float>(uvd.y() + noise(rng));
    o.d_px = static_cast<float>(uvd.z() + noise(rng));
    if (k == 5) o.d_px += 8.0f;  // a wrong association
    obs.push_back(o);
  }
  Eigen::Vector3d p = p_true + Eigen::Vector3d(0.3, -0.2, 0.1);
  ASSERT_EQ(refineLandmark(rig, rig.T_b_cl, obs, RefineOptions(), &p), RefineResult::kOk);
  // 12 views with 0.3 px noise at ~4 m: a few centimetres.
  constexpr double kRefineTolM = 0.05;
  EXPECT_LT((p - p_true).norm(), kRefineTolM) << p.transpose();
  std::vector<Observation> one(obs.begin(), obs.begin() + 1);
  EXPECT_EQ(refineLandmark(rig, rig.T_b_cl, one, RefineOptions(), &p),
            RefineResult::kTooFewObservations);

  // Every later view 2 px nearer than the anchor says (odometry drift, or a neighbouring
  // corner): the refinement would move the anchor disparity by ~2 px > 2 sigma and is refused.
  std::vector<Observation> drifted = obs;
  drifted[5].d_px -= 8.0f;
  for (size_t k = 1; k < drifted.size(); ++k) drifted[k].d_px += 2.0f;
  Eigen::Vector3d q = p_true;
  EXPECT_EQ(refineLandmark(rig, rig.T_b_cl, drifted, RefineOptions(), &q),
            RefineResult::kDisagreesWithAnchor);
  EXPECT_EQ(q, p_true);  // unchanged
  RefineOptions permissive;
  permissive.max_anchor_shift_sigmas = 100.0;
  EXPECT_EQ(refineLandmark(rig, rig.T_b_cl, drifted, permissive, &q), RefineResult::kOk);
  EXPECT_GT((q - p_true).norm(), kRefineTolM);
}

}  // namespace
}  // namespace twocam::landmarks
