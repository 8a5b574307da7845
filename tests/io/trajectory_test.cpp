#include "io/trajectory.h"

#include <gtest/gtest.h>

#include <random>

#include "eval/trajectory_metrics.h"

namespace twocam {
namespace {

constexpr double kPositionTolM = 1e-6;
constexpr double kRotationTol = 1e-8;

std::vector<io::TimedPose> randomTrack(uint64_t seed, int n) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::vector<io::TimedPose> track;
  for (int i = 0; i < n; ++i) {
    io::TimedPose p;
    p.t_ns = 1'700'000'000'000'000'000LL + i * 66'666'667LL;
    p.T_w_b.linear() =
        Eigen::AngleAxisd(u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).matrix();
    p.T_w_b.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng));
    track.push_back(p);
  }
  return track;
}

TEST(Trajectory, TumRoundTripKeepsPosesAndTimes) {
  const auto track = randomTrack(/*seed=*/3, 50);
  const std::string text = io::toTum(track, "odometry");
  EXPECT_EQ(text.rfind("# odometry\n", 0), 0u);
  std::vector<io::TimedPose> back;
  ASSERT_TRUE(io::parseTum(text, &back).isOk());
  ASSERT_EQ(back.size(), track.size());
  for (size_t i = 0; i < track.size(); ++i) {
    // The text has 9 decimals of seconds; parsing goes through a double (~0.3 us at 1.7e9 s).
    EXPECT_NEAR(static_cast<double>(back[i].t_ns - track[i].t_ns), 0.0, 1000.0);
    EXPECT_LT((back[i].T_w_b.translation() - track[i].T_w_b.translation()).norm(), kPositionTolM);
    EXPECT_LT((back[i].T_w_b.linear() - track[i].T_w_b.linear()).norm(), kRotationTol * 100);
  }
}

TEST(Trajectory, ParseRejectsBadLines) {
  std::vector<io::TimedPose> poses;
  EXPECT_FALSE(io::parseTum("0 1 2 3 0 0 0\n", &poses).isOk());
  EXPECT_FALSE(io::parseTum("0 1 2 3 0 0 0 1 9\n", &poses).isOk());
  EXPECT_FALSE(io::parseTum("0 1 x 3 0 0 0 1\n", &poses).isOk());
  EXPECT_FALSE(io::parseTum("0 1 2 3 0 0 0 2\n", &poses).isOk());
  const Status s = io::parseTum("# c\n0 1 2 3 0 0 0 1\n0 nan 2 3 0 0 0 1\n", &poses);
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("line 3"), std::string::npos) << s.message();
}

TEST(Trajectory, AteIsTheRmsOfPositionDifferences) {
  auto truth = randomTrack(/*seed=*/5, 4);
  auto estimate = truth;
  const double offsets[] = {0.0, 0.1, 0.2, 0.4};
  for (int i = 0; i < 4; ++i) estimate[i].T_w_b.translation().x() += offsets[i];
  double rmse = 0.0;
  ASSERT_TRUE(eval::ateRmseM(estimate, truth, &rmse).isOk());
  EXPECT_NEAR(rmse, std::sqrt((0.01 + 0.04 + 0.16) / 4.0), 1e-12);
  estimate.pop_back();
  EXPECT_FALSE(eval::ateRmseM(estimate, truth, &rmse).isOk());
  estimate.push_back(truth.back());
  estimate.back().t_ns += 1;
  EXPECT_FALSE(eval::ateRmseM(estimate, truth, &rmse).isOk());
  EXPECT_FALSE(eval::ateRmseM({}, {}, &rmse).isOk());
}

}  // namespace
}  // namespace twocam
