#include "common/rig.h"

#include <gtest/gtest.h>

#include <random>

#include "common/random.h"

namespace twocam {
namespace {

// Double precision, well-conditioned geometry (points 0.3 m to 80 m, disparities > 0.5 px).
constexpr double kRoundTripRelTol = 1e-9;
constexpr double kRotationTol = 1e-12;
constexpr int kTrials = 1000;

TEST(StereoRig, TriangulateInvertsProjectionOverSeededTrials) {
  StereoRig rig;
  std::mt19937_64 rng = makeRng(7, RandomStream::kTextures);
  std::uniform_real_distribution<double> uu(0.0, rig.width_px - 1.0), vv(0.0, rig.height_px - 1.0),
      zz(0.3, 80.0);
  for (int i = 0; i < kTrials; ++i) {
    const double z = zz(rng);
    // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to left,
    // kept)
    const double v_draw = vv(rng);
    const double u_draw = uu(rng);
    const Eigen::Vector2d uv(u_draw, v_draw);
    const Eigen::Vector3d p(
        (uv.x() - rig.cx_px) * z / rig.fx_px, (uv.y() - rig.cy_px) * z / rig.fy_px, z);
    Eigen::Vector2d uv2;
    ASSERT_TRUE(projectLeft(rig, p, &uv2));
    EXPECT_NEAR((uv2 - uv).norm(), 0.0, kRoundTripRelTol * rig.width_px);
    const double d = rig.fx_px * rig.baseline_m / z;
    const auto q = triangulateRectified(rig, uv2, d);
    ASSERT_TRUE(q.has_value());
    EXPECT_NEAR((*q - p).norm(), 0.0, kRoundTripRelTol * z);
  }
}

TEST(StereoRig, RejectsPointsBehindAndNonPositiveDisparity) {
  StereoRig rig;
  Eigen::Vector2d uv;
  EXPECT_FALSE(projectLeft(rig, Eigen::Vector3d(0, 0, -1), &uv));
  EXPECT_FALSE(projectLeft(rig, Eigen::Vector3d(0, 0, 0), &uv));
  EXPECT_FALSE(triangulateRectified(rig, Eigen::Vector2d(1, 1), 0.0).has_value());
  EXPECT_FALSE(triangulateRectified(rig, Eigen::Vector2d(1, 1), -2.0).has_value());
}

TEST(StereoRig, ValidateNamesTheBrokenField) {
  StereoRig rig;
  EXPECT_TRUE(rig.validate().isOk());
  rig.baseline_m = -0.1;
  EXPECT_NE(rig.validate().message().find("baseline_m"), std::string::npos);
  rig = StereoRig();
  rig.fx_px = 0.0;
  EXPECT_FALSE(rig.validate().isOk());
  rig = StereoRig();
  rig.width_px = 4;
  EXPECT_FALSE(rig.validate().isOk());
}

TEST(StereoRig, RightCameraSitsAtPlusBaselineAlongX) {
  StereoRig rig;
  rig.baseline_m = 0.2;
  const Eigen::Isometry3d T = rig.T_cl_cr();
  EXPECT_NEAR((T.translation() - Eigen::Vector3d(0.2, 0, 0)).norm(), 0.0, kRotationTol);
  EXPECT_TRUE(T.linear().isIdentity(kRotationTol));
}

TEST(OpticalRotation, LooksAlongBodyXWithImageDownAlongMinusZ) {
  const Eigen::Matrix3d R = opticalRotationFromYawPitch(0.0, 0.0);
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d::UnitX(), kRotationTol));   // optical z = forward
  EXPECT_TRUE(R.col(0).isApprox(-Eigen::Vector3d::UnitY(), kRotationTol));  // x = right
  EXPECT_TRUE(R.col(1).isApprox(-Eigen::Vector3d::UnitZ(), kRotationTol));  // y = down
  EXPECT_NEAR(R.determinant(), 1.0, kRotationTol);
  // Positive pitch looks down; yaw turns the view to the left.
  EXPECT_LT(opticalRotationFromYawPitch(0.0, 0.2).col(2).z(), 0.0);
  EXPECT_GT(opticalRotationFromYawPitch(0.3, 0.0).col(2).y(), 0.0);
}

}  // namespace
}  // namespace twocam
