#include "eval/trajectory_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace twocam::eval {
namespace {

/// Sums of a few hundred metre-scale terms.
constexpr double kErrorTol = 1e-9;

/// A straight drive along x, `step_m` per pose, 10 Hz.
std::vector<io::TimedPose> straight(int n, double step_m, double yaw_rate_rad_per_m = 0.0) {
  std::vector<io::TimedPose> track;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < n; ++i) {
    track.push_back({int64_t{100'000'000} * i, T});
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    step.translation() = Eigen::Vector3d(step_m, 0.0, 0.0);
    step.linear() =
        Eigen::AngleAxisd(yaw_rate_rad_per_m * step_m, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T = T * step;
  }
  return track;
}

TEST(TrajectoryMetrics, RelativeErrorOfAScaleErrorIsItsPercentage) {
  // Steps of 1/8 m add up to 1 m exactly, so every segment is 8 steps long.
  const std::vector<io::TimedPose> truth = straight(51, 0.125);  // 6.25 m
  const std::vector<io::TimedPose> est = straight(51, 0.1275);   // reports 2 % too far
  RelativePoseError rpe;
  ASSERT_TRUE(relativePoseError(est, truth, 1.0, &rpe).isOk());
  EXPECT_EQ(rpe.pairs, 43);  // start poses 0..42 have a pose 1 m of true travel later
  EXPECT_NEAR(rpe.trans_pct, 2.0, kErrorTol);
  EXPECT_NEAR(rpe.rot_deg_per_m, 0.0, kErrorTol);
  double ate = 0.0;
  ASSERT_TRUE(ateRmseM(truth, truth, &ate).isOk());
  EXPECT_EQ(ate, 0.0);
}

TEST(TrajectoryMetrics, RelativeErrorOfAHeadingDriftIsDegreesPerMetre) {
  const std::vector<io::TimedPose> truth = straight(51, 0.125);
  const double drift_rad_per_m = 0.5 * M_PI / 180.0;
  const std::vector<io::TimedPose> est = straight(51, 0.125, drift_rad_per_m);
  RelativePoseError rpe;
  ASSERT_TRUE(relativePoseError(est, truth, 1.0, &rpe).isOk());
  EXPECT_NEAR(rpe.rot_deg_per_m, 0.5, 1e-6);
  EXPECT_GT(rpe.trans_pct, 0.0);  // the curved track ends beside the straight one
}

TEST(TrajectoryMetrics, ShortPathsHaveNoSegmentAndBadInputIsAnError) {
  const std::vector<io::TimedPose> truth = straight(5, 0.1);  // 0.4 m
  RelativePoseError rpe;
  ASSERT_TRUE(relativePoseError(truth, truth, 1.0, &rpe).isOk());
  EXPECT_EQ(rpe.pairs, 0);
  EXPECT_TRUE(std::isnan(rpe.trans_pct));
  EXPECT_TRUE(std::isnan(rpe.rot_deg_per_m));
  EXPECT_FALSE(relativePoseError(straight(4, 0.1), truth, 1.0, &rpe).isOk());
  EXPECT_FALSE(relativePoseError(truth, truth, 0.0, &rpe).isOk());
  std::vector<io::TimedPose> shifted = truth;
  shifted[2].t_ns += 1;
  const Status st = relativePoseError(shifted, truth, 1.0, &rpe);
  ASSERT_FALSE(st.isOk());
  EXPECT_NE(st.message().find("pose 2"), std::string::npos) << st.message();
}

}  // namespace
}  // namespace twocam::eval
