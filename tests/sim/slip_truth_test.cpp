// The true slip events of a log: the frame each lands on, and the sidecar CSV round trip.
#include "sim/slip_truth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "sim/wheel_odometry.h"

namespace twocam::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;
/// The CSV keeps 9 significant digits.
constexpr double kCsvTol = 1e-9;

TEST(SlipTruth, FramesAtARateAreTheSimulatorsCeiling) {
  const std::vector<TrueSlip> s =
      slipsAtFrameRate({{9.0, 0.04, 0.0, 1.5 * kDeg}, {12.01, 0.03, 0.01, 3.0 * kDeg}}, 15.0);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].frame, 135);
  EXPECT_EQ(s[1].frame, 181);
}

TEST(SlipTruth, FramesAlongTimeStampsAreWhereTheSyntheticOdometryPutsThem) {
  // Uneven stamps (KITTI's times.txt): 0, 0.1, 0.25, 0.3, 0.5 s.
  const std::vector<int64_t> t_ns = {
      1'000'000'000, 1'100'000'000, 1'250'000'000, 1'300'000'000, 1'500'000'000};
  const std::vector<SlipEvent> events = {
      {0.0, 0.1, 0.0, 0.0}, {0.2, 0.1, 0.0, 0.0}, {0.3, 0.0, 0.0, 2.0 * kDeg}, {0.6, 0.1, 0, 0}};
  const std::vector<TrueSlip> s = slipsAtTimes(events, t_ns);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[0].frame, 1);   // applied with the first increment
  EXPECT_EQ(s[1].frame, 2);   // the first frame at or after 0.2 s
  EXPECT_EQ(s[2].frame, 3);   // exactly 0.3 s
  EXPECT_EQ(s[3].frame, -1);  // after the log's end

  // The synthetic odometry's step jumps by the slip exactly at those frames.
  std::vector<Eigen::Isometry3d> still(t_ns.size(), Eigen::Isometry3d::Identity());
  OdometryNoiseSpec noise;
  noise.sigma_per_m = 0.0;
  noise.sigma_per_rad = 0.0;
  noise.slips = {events[1], events[2]};
  const std::vector<Pose2> odo = syntheticOdometry(t_ns, still, noise, 1);
  EXPECT_DOUBLE_EQ(odo[1].x_m, 0.0);
  EXPECT_DOUBLE_EQ(odo[2].x_m, 0.1);
  EXPECT_DOUBLE_EQ(odo[2].yaw_rad, 0.0);
  EXPECT_DOUBLE_EQ(odo[3].yaw_rad, 2.0 * kDeg);
}

TEST(SlipTruth, TheCsvReadsBackWhatItWrote) {
  const std::vector<TrueSlip> in = {{15, {1.5, 0.1, 0.0, 0.0}}, {-1, {3.5, 0.0, -0.02, 3 * kDeg}}};
  std::vector<TrueSlip> out;
  ASSERT_TRUE(parseSlipsCsv(slipsCsv(in), "x.slips.csv", &out).isOk());
  ASSERT_EQ(out.size(), in.size());
  for (size_t i = 0; i < in.size(); ++i) {
    EXPECT_EQ(out[i].frame, in[i].frame);
    EXPECT_NEAR(out[i].event.time_s, in[i].event.time_s, kCsvTol);
    EXPECT_NEAR(out[i].event.dy_m, in[i].event.dy_m, kCsvTol);
    EXPECT_NEAR(out[i].event.dyaw_rad, in[i].event.dyaw_rad, kCsvTol);
  }
  EXPECT_EQ(slipsSidecarPath("/data/k1.rawlog"), "/data/k1.slips.csv");
  EXPECT_EQ(slipsSidecarPath("k1.rawlog"), "./k1.slips.csv");
}

TEST(SlipTruth, BadFilesNameThePathAndLine) {
  struct Case {
    std::string text;
    std::string expected;
  };
  const std::string h = "frame,time_s,dx_m,dy_m,dyaw_deg\n";
  const std::vector<Case> cases = {
      {"", "s.csv:1: expected the header"},
      {"frame,t\n", "s.csv:1: expected the header"},
      {h + "15,1.5,0.1,0\n", "s.csv:2: expected 5 columns, got 4"},
      {h + "15,1.5,0.1,0,0\n15,nan,0,0,0\n", "s.csv:3: 'nan' is not a finite number"},
      {h + "15,1.5x,0.1,0,0\n", "s.csv:2: '1.5x' is not a finite number"},
      {h + "1.5,1.5,0.1,0,0\n", "s.csv:2: frame 1.5: must be a whole number >= -1"},
      {h + "-2,1.5,0.1,0,0\n", "s.csv:2: frame -2"},
      {h + "3,-1,0.1,0,0\n", "s.csv:2: time_s -1: must be >= 0"},
  };
  for (const Case& c : cases) {
    std::vector<TrueSlip> out;
    const Status st = parseSlipsCsv(c.text, "s.csv", &out);
    ASSERT_FALSE(st.isOk()) << c.text;
    EXPECT_NE(st.message().find(c.expected), std::string::npos) << st.message();
  }
  std::vector<TrueSlip> out;
  const Status missing = loadSlipsCsv("/nonexistent/k.slips.csv", &out);
  ASSERT_FALSE(missing.isOk());
  EXPECT_NE(missing.message().find("/nonexistent/k.slips.csv"), std::string::npos);
}

}  // namespace
}  // namespace twocam::sim
