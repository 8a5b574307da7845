#include "pipeline/map_recorder.h"

#include <gtest/gtest.h>

#include <random>

#include "common/frames.h"
#include "common/rig.h"

namespace twocam::pipeline {
namespace {

TEST(MapRecorder, StereoCovarianceMatchesSampledTriangulations) {
  // First-order propagation against the spread of triangulations of noisy (u, v, d), seeded.
  StereoRig rig;
  const Eigen::Isometry3d T_w_cl = toIsometry(Pose2{1.0, 2.0, 0.7}) * rig.T_b_cl;
  const double u = 400.0, v = 300.0, d = 40.0, sigma = 0.5, sigma_d = 0.5;
  Eigen::Matrix3d cov;
  ASSERT_TRUE(stereoPointCovariance(rig, T_w_cl, u, v, d, sigma, sigma_d, &cov));
  std::mt19937_64 rng(20261203);
  std::normal_distribution<double> n(0.0, 1.0);
  const auto triangulate = [&](double uu, double vv, double dd) {
    const double z = rig.fx_px * rig.baseline_m / dd;
    return T_w_cl *
           Eigen::Vector3d((uu - rig.cx_px) * z / rig.fx_px, (vv - rig.cy_px) * z / rig.fy_px, z);
  };
  constexpr int kSamples = 20000;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < kSamples; ++i) {
    // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to left,
    // kept)
    const double d_noisy = d + sigma_d * n(rng);
    const double v_noisy = v + sigma * n(rng);
    const double u_noisy = u + sigma * n(rng);
    pts.push_back(triangulate(u_noisy, v_noisy, d_noisy));
    mean += pts.back();
  }
  mean /= kSamples;
  Eigen::Matrix3d sampled = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : pts) sampled += (p - mean) * (p - mean).transpose();
  sampled /= kSamples - 1;
  // Depth is nonlinear in d (1/d): at d = 40 px a 0.5 px sigma bends it by about 1 %, and the
  // sampling error of 20 000 draws is about 1 % too.
  constexpr double kRelTol = 0.05;
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(cov(r, r), sampled(r, r), kRelTol * sampled(r, r)) << r;
  }
  EXPECT_FALSE(stereoPointCovariance(rig, T_w_cl, u, v, 0.0, sigma, sigma_d, &cov));
}

TEST(MapRecorder, OptionsNameTheirKey) {
  MapRecorderOptions o;
  EXPECT_TRUE(o.validate().isOk());
  o.frames_per_commit = 0;
  EXPECT_NE(o.validate().message().find("frames_per_commit"), std::string::npos);
  o = MapRecorderOptions();
  o.merge_radius_m = -0.01;
  EXPECT_NE(o.validate().message().find("merge_radius_m"), std::string::npos);
  o = MapRecorderOptions();
  o.merge_max_descriptor_distance = 3.0;
  EXPECT_NE(o.validate().message().find("merge_max_descriptor_distance"), std::string::npos);
}

}  // namespace
}  // namespace twocam::pipeline
