#include "common/odometry_noise.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace twocam {
namespace {

constexpr double kTol = 1e-15;  // a few operations in double

TEST(OdometryNoise, RandomIncrementSigmaGrowsWithTheRootOfTheIncrement) {
  EXPECT_EQ(randomIncrementSigma(0.02, 0.0), 0.0);
  EXPECT_NEAR(randomIncrementSigma(0.02, 4.0), 0.04, kTol);
  EXPECT_EQ(randomIncrementSigma(0.02, -4.0), randomIncrementSigma(0.02, 4.0));  // reversing
}

TEST(OdometryNoise, AccumulatedSigmaAddsRandomWalkAndSystematicParts) {
  const OdometryNoise noise;
  const OdometryErrorSigma zero = accumulatedOdometrySigma(noise, 0.0, 0.0);
  EXPECT_EQ(zero.trans_m, 0.0);
  EXPECT_EQ(zero.yaw_rad, 0.0);
  const OdometryErrorSigma s = accumulatedOdometrySigma(noise, 4.0, -1.0);
  EXPECT_NEAR(s.trans_m, noise.trans_sigma_per_sqrt_m * 2.0 + noise.trans_scale_sigma * 4.0, kTol);
  EXPECT_NEAR(s.yaw_rad,
              noise.rot_sigma_per_sqrt_rad + noise.rot_scale_sigma + noise.rot_sigma_per_m * 4.0,
              kTol);
  // A negative path (never produced by the tracker) counts as none.
  EXPECT_EQ(accumulatedOdometrySigma(noise, -1.0, 0.0).trans_m, 0.0);
}

TEST(OdometryNoise, ValidateNamesTheFieldAndBoundsIt) {
  OdometryNoise noise;
  EXPECT_TRUE(noise.validate().isOk());
  noise.rot_scale_sigma = -0.1;
  EXPECT_EQ(noise.validate("x.").message(), "x.rot_scale_sigma = -0.1; must be in [0, 1]");
  noise = OdometryNoise();
  noise.trans_sigma_per_sqrt_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(noise.validate().isOk());
  noise = OdometryNoise();
  noise.rot_sigma_per_m = 1.5;
  EXPECT_FALSE(noise.validate().isOk());
}

}  // namespace
}  // namespace twocam
