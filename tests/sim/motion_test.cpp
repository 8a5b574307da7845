#include "sim/motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "sim/world.h"

namespace twocam::sim {
namespace {

/// Noise-free odometry repeats the true integration with identical arithmetic, so the poses
/// are bitwise equal; the tolerance only absorbs a compiler contracting one side differently.
constexpr double kExactTol = 1e-12;
/// Statistical checks accept the estimate within this many standard errors of the model:
/// a false failure has probability ~6e-5 per check, and every check is seeded anyway.
constexpr double kStatSigmas = 4.0;
/// Monte Carlo runs per statistical check: the standard error of a sample standard deviation
/// is then 1.6 % of it, so a 10 % model error would be caught, and the test stays fast.
constexpr int kMonteCarloRuns = 2000;
/// Yaw rate and speed bounds hold exactly up to rounding of the angle wrap.
constexpr double kRateTol = 1e-12;
constexpr int64_t kStartNs = 1'000'000'000;

OdometryNoiseSpec zeroNoise() {
  OdometryNoiseSpec n;
  n.sigma_per_m = 0.0;
  n.sigma_per_rad = 0.0;
  n.scale_error = 0.0;
  n.wheel_base_error = 0.0;
  return n;
}

/// 3 m square, looping: four 90-degree turns per lap.
RobotSpec squarePath() {
  RobotSpec r;
  r.waypoints = {{0.0, 0.0}, {3.0, 0.0}, {3.0, 3.0}, {0.0, 3.0}};
  r.loop = true;
  return r;
}

/// Straight 1 m run that stops at its end.
RobotSpec straightMetre() {
  RobotSpec r;
  r.waypoints = {{0.0, 0.0}, {1.0, 0.0}};
  r.loop = false;
  return r;
}

/// 1 m forward, a left turn of about 90 degrees, then 1 m up; stops at the end.
RobotSpec leftTurn() {
  RobotSpec r;
  r.waypoints = {{0.0, 0.0}, {1.0, 0.0}, {1.0, 1.0}};
  r.loop = false;
  return r;
}

std::vector<MotionSample> run(const RobotSpec& robot,
                              const OdometryNoiseSpec& noise,
                              uint64_t seed,
                              int frames) {
  MotionSimulator sim(robot, noise, seed, kStartNs);
  std::vector<MotionSample> out;
  out.reserve(static_cast<size_t>(frames));
  for (int k = 0; k < frames; ++k) out.push_back(sim.next());
  return out;
}

double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }

/// Frames a stopping path needs: cruise time plus a margin for slow turns and the braking
/// before the last waypoint (about 6 s with the default speed and yaw rate).
int framesToFinish(const RobotSpec& r, double length_m) {
  constexpr double kTurnAndBrakeMarginS = 10.0;
  return static_cast<int>((length_m / r.speed_mps + kTurnAndBrakeMarginS) * r.frame_rate_hz);
}

struct SampleStats {
  double mean = 0.0;
  double std = 0.0;
};

SampleStats stats(const std::vector<double>& x) {
  SampleStats s;
  for (double v : x) s.mean += v;
  s.mean /= static_cast<double>(x.size());
  double ss = 0.0;
  for (double v : x) ss += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(ss / static_cast<double>(x.size() - 1));
  return s;
}

/// Checks sample mean and standard deviation of normal data against the model, each within
/// kStatSigmas standard errors computed from the model's standard deviation.
void expectMatchesNormal(const std::vector<double>& x,
                         double expected_mean,
                         double expected_std,
                         const char* what) {
  const SampleStats s = stats(x);
  const auto n = static_cast<double>(x.size());
  const double se_mean = expected_std / std::sqrt(n);
  const double se_std = expected_std / std::sqrt(2.0 * (n - 1.0));
  EXPECT_NEAR(s.mean, expected_mean, kStatSigmas * se_mean)
      << what << ": mean " << s.mean << " vs model " << expected_mean;
  EXPECT_NEAR(s.std, expected_std, kStatSigmas * se_std)
      << what << ": std " << s.std << " vs model " << expected_std;
  std::cout << "[          ] " << what << ": mean " << s.mean << " (model " << expected_mean
            << ", SE " << se_mean << "), std " << s.std << " (model " << expected_std << ", SE "
            << se_std << ")\n";
}

void expectPoseNear(const Pose2& a, const Pose2& b, double tol, int frame) {
  EXPECT_NEAR(a.x_m, b.x_m, tol) << "frame " << frame;
  EXPECT_NEAR(a.y_m, b.y_m, tol) << "frame " << frame;
  EXPECT_NEAR(wrap(a.yaw_rad - b.yaw_rad), 0.0, tol) << "frame " << frame;
}

TEST(IntegrateIncrement, MovesAlongMeanHeadingAndWrapsYaw) {
  Pose2 p;
  p.x_m = 1.0;
  p.y_m = 2.0;
  p.yaw_rad = 3.0;
  const Pose2 q = integrateIncrement(p, 0.5, 0.4);
  EXPECT_NEAR(q.x_m, 1.0 + 0.5 * std::cos(3.2), kExactTol);
  EXPECT_NEAR(q.y_m, 2.0 + 0.5 * std::sin(3.2), kExactTol);
  EXPECT_NEAR(q.yaw_rad, 3.4 - 2.0 * M_PI, kExactTol);
  EXPECT_GT(q.yaw_rad, -M_PI);
  EXPECT_LE(q.yaw_rad, M_PI);
}

TEST(MotionSimulator, FirstFrameIsStartPoseHeadingForSecondWaypoint) {
  RobotSpec r;
  r.waypoints = {{1.0, 2.0}, {1.0, 5.0}};
  MotionSimulator sim(r, OdometryNoiseSpec{}, 3, kStartNs);
  const MotionSample s = sim.next();
  EXPECT_EQ(s.t_ns, kStartNs);
  EXPECT_EQ(s.true_pose.x_m, 1.0);
  EXPECT_EQ(s.true_pose.y_m, 2.0);
  EXPECT_NEAR(s.true_pose.yaw_rad, M_PI / 2.0, kExactTol);
  EXPECT_EQ(s.odom_pose.x_m, s.true_pose.x_m);
  EXPECT_EQ(s.odom_pose.yaw_rad, s.true_pose.yaw_rad);
  EXPECT_EQ(s.true_distance_m, 0.0);
  EXPECT_EQ(s.true_turned_rad, 0.0);
}

TEST(MotionSimulator, TimestampsFollowFrameRate) {
  RobotSpec r = squarePath();
  r.frame_rate_hz = 30.0;
  const auto samples = run(r, zeroNoise(), 1, 100);
  for (size_t k = 0; k < samples.size(); ++k) {
    EXPECT_EQ(samples[k].t_ns, kStartNs + std::llround(static_cast<double>(k) * 1e9 / 30.0));
  }
}

TEST(MotionSimulator, ZeroNoiseOdometryEqualsTruth) {
  const auto samples = run(squarePath(), zeroNoise(), 5, 600);
  for (size_t k = 0; k < samples.size(); ++k) {
    expectPoseNear(samples[k].odom_pose, samples[k].true_pose, kExactTol, static_cast<int>(k));
  }
  // The run must contain turns, or the check above would prove little.
  EXPECT_GT(samples.back().true_turned_rad, 2.0 * M_PI);
}

TEST(ScaledOdometryNoise, ZeroScaleGivesExactOdometryAndThreeTriplesEveryError) {
  OdometryNoiseSpec spec;
  spec.sigma_per_m = 0.02;
  spec.sigma_per_rad = 0.03;
  spec.scale_error = 0.01;
  spec.wheel_base_error = 0.01;
  spec.slips = {{9.0, 0.04, 0.01, 0.02}};
  const OdometryNoiseSpec none = scaledOdometryNoise(spec, 0.0);
  const auto samples = run(squarePath(), none, 5, 300);
  for (size_t k = 0; k < samples.size(); ++k) {
    expectPoseNear(samples[k].odom_pose, samples[k].true_pose, kExactTol, static_cast<int>(k));
  }
  const OdometryNoiseSpec triple = scaledOdometryNoise(spec, 3.0);
  EXPECT_DOUBLE_EQ(triple.sigma_per_m, 0.06);
  EXPECT_DOUBLE_EQ(triple.sigma_per_rad, 0.09);
  EXPECT_DOUBLE_EQ(triple.scale_error, 0.03);
  EXPECT_DOUBLE_EQ(triple.wheel_base_error, 0.03);
  ASSERT_EQ(triple.slips.size(), 1u);
  EXPECT_DOUBLE_EQ(triple.slips[0].time_s, 9.0);  // when it slips does not scale
  EXPECT_DOUBLE_EQ(triple.slips[0].dx_m, 0.12);
  EXPECT_DOUBLE_EQ(triple.slips[0].dy_m, 0.03);
  EXPECT_DOUBLE_EQ(triple.slips[0].dyaw_rad, 0.06);
}

TEST(MotionSimulator, PassesNearAllWaypointsWithBoundedRates) {
  const RobotSpec r = squarePath();
  // One lap is about 12 m at <= 0.4 m/s; 1.5 laps make sure waypoint 0 is revisited.
  const auto samples = run(r, zeroNoise(), 1, static_cast<int>(1.5 * 12.0 / r.speed_mps * 15.0));
  // Switching is checked every substep; frames sample every kSubstepsPerFrame, so the closest
  // frame can be up to one frame's travel farther than the radius.
  const double slack_m = r.speed_mps / r.frame_rate_hz;
  for (size_t w = 0; w < r.waypoints.size(); ++w) {
    double closest = 1e9;
    // Skip the start so waypoint 0 must be revisited after a lap.
    for (size_t k = 1; k < samples.size(); ++k) {
      const Eigen::Vector2d p(samples[k].true_pose.x_m, samples[k].true_pose.y_m);
      if (w == 0 && samples[k].true_distance_m < 6.0) continue;
      closest = std::min(closest, (p - r.waypoints[w]).norm());
    }
    EXPECT_LE(closest, r.waypoint_radius_m + slack_m) << "waypoint " << w;
  }
  const double max_dyaw = r.max_yaw_rate_rps / r.frame_rate_hz;
  const double max_ds = r.speed_mps / r.frame_rate_hz;
  for (size_t k = 1; k < samples.size(); ++k) {
    const double dyaw = wrap(samples[k].true_pose.yaw_rad - samples[k - 1].true_pose.yaw_rad);
    EXPECT_LE(std::abs(dyaw), max_dyaw + kRateTol) << "frame " << k;
    const double dturn = samples[k].true_turned_rad - samples[k - 1].true_turned_rad;
    EXPECT_LE(dturn, max_dyaw + kRateTol) << "frame " << k;
    const double ds = samples[k].true_distance_m - samples[k - 1].true_distance_m;
    EXPECT_LE(ds, max_ds + kRateTol) << "frame " << k;
    EXPECT_GT(ds, 0.0) << "a looping robot never stops, frame " << k;
  }
}

TEST(MotionSimulator, StopsAtLastWaypointWithoutLoop) {
  // The robot brakes and homes in on the last waypoint, also after a sharp turn onto a final
  // leg shorter than its turning circle or behind it (measured stop error <= 7.4e-5 m).
  constexpr double kStopTolM = 1e-3;
  for (const Eigen::Vector2d& last :
       {Eigen::Vector2d(2.0, 1.5), Eigen::Vector2d(2.0, -0.3), Eigen::Vector2d(1.5, 0.4)}) {
    RobotSpec r;
    r.waypoints = {{0.0, 0.0}, {2.0, 0.0}, last};
    r.loop = false;
    const auto samples = run(r, zeroNoise(), 1, framesToFinish(r, 4.0) + 50);
    const MotionSample& end = samples.back();
    EXPECT_NEAR(end.true_pose.x_m, last.x(), kStopTolM);
    EXPECT_NEAR(end.true_pose.y_m, last.y(), kStopTolM);
    // Stationary for the last 50 frames: nothing moves, nothing accumulates.
    for (size_t k = samples.size() - 50; k < samples.size(); ++k) {
      EXPECT_EQ(samples[k].true_pose.x_m, end.true_pose.x_m);
      EXPECT_EQ(samples[k].true_pose.y_m, end.true_pose.y_m);
      EXPECT_EQ(samples[k].true_pose.yaw_rad, end.true_pose.yaw_rad);
      EXPECT_EQ(samples[k].true_distance_m, end.true_distance_m);
      EXPECT_EQ(samples[k].odom_pose.x_m, end.odom_pose.x_m);
    }
  }
}

TEST(MotionSimulator, SameSeedSameOutputDifferentSeedDifferentOutput) {
  OdometryNoiseSpec n;
  n.sigma_per_m = 0.05;
  n.sigma_per_rad = 0.05;
  n.scale_error = 0.01;
  n.wheel_base_error = 0.02;
  n.slips = {{2.0, 0.1, 0.0, 0.05}};
  const auto a = run(squarePath(), n, 42, 300);
  const auto b = run(squarePath(), n, 42, 300);
  const auto c = run(squarePath(), n, 43, 300);
  bool any_difference = false;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].t_ns, b[k].t_ns);
    EXPECT_EQ(a[k].odom_pose.x_m, b[k].odom_pose.x_m);
    EXPECT_EQ(a[k].odom_pose.y_m, b[k].odom_pose.y_m);
    EXPECT_EQ(a[k].odom_pose.yaw_rad, b[k].odom_pose.yaw_rad);
    EXPECT_EQ(a[k].true_pose.x_m, c[k].true_pose.x_m) << "truth must not depend on the seed";
    any_difference = any_difference || a[k].odom_pose.x_m != c[k].odom_pose.x_m;
  }
  EXPECT_TRUE(any_difference);
}

/// Final along-track odometry error of a straight 1 m run, one entry per seed.
std::vector<double> distanceErrors(const RobotSpec& r,
                                   const OdometryNoiseSpec& n,
                                   double* length_m) {
  std::vector<double> err;
  const int frames = framesToFinish(r, 1.0);
  for (int seed = 0; seed < kMonteCarloRuns; ++seed) {
    MotionSimulator sim(r, n, static_cast<uint64_t>(seed), kStartNs);
    MotionSample s;
    for (int k = 0; k < frames; ++k) s = sim.next();
    EXPECT_EQ(s.odom_pose.y_m, 0.0) << "no heading error is active";
    err.push_back(s.odom_pose.x_m - s.true_pose.x_m);
    *length_m = s.true_distance_m;
  }
  return err;
}

TEST(MotionSimulator, DistanceRandomWalkHasModelStdAtAnyFrameRate) {
  OdometryNoiseSpec n = zeroNoise();
  n.sigma_per_m = 0.02;
  // The variance per metre must not depend on how finely the motion is sampled.
  for (double rate_hz : {15.0, 60.0}) {
    RobotSpec r = straightMetre();
    r.frame_rate_hz = rate_hz;
    double length_m = 0.0;
    const auto err = distanceErrors(r, n, &length_m);
    ASSERT_NEAR(length_m, 1.0, kExactTol) << "the robot lands on the final waypoint";
    expectMatchesNormal(err,
                        0.0,
                        n.sigma_per_m * std::sqrt(length_m),
                        rate_hz == 15.0 ? "distance error 15 Hz" : "distance error 60 Hz");
  }
}

TEST(MotionSimulator, ScaleErrorBiasesDistanceExactly) {
  OdometryNoiseSpec n = zeroNoise();
  n.scale_error = 0.03;
  const RobotSpec r = straightMetre();
  const auto samples = run(r, n, 1, framesToFinish(r, 1.0));
  for (const MotionSample& s : samples) {
    EXPECT_NEAR(s.odom_pose.x_m - s.true_pose.x_m, n.scale_error * s.true_distance_m, kExactTol);
  }
}

TEST(MotionSimulator, ScaleAndRandomWalkTogetherGiveBiasAndSpread) {
  OdometryNoiseSpec n = zeroNoise();
  n.scale_error = 0.01;
  n.sigma_per_m = 0.02;
  double length_m = 0.0;
  const auto err = distanceErrors(straightMetre(), n, &length_m);
  expectMatchesNormal(
      err, n.scale_error * length_m, n.sigma_per_m * std::sqrt(length_m), "biased distance error");
}

TEST(MotionSimulator, HeadingRandomWalkHasModelStd) {
  OdometryNoiseSpec n = zeroNoise();
  n.sigma_per_rad = 0.02;
  const RobotSpec r = leftTurn();
  const int frames = framesToFinish(r, 2.0);
  std::vector<double> err;
  double turned_rad = -1.0;
  for (int seed = 0; seed < kMonteCarloRuns; ++seed) {
    MotionSimulator sim(r, n, static_cast<uint64_t>(seed), kStartNs);
    MotionSample s;
    for (int k = 0; k < frames; ++k) s = sim.next();
    err.push_back(wrap(s.odom_pose.yaw_rad - s.true_pose.yaw_rad));
    if (turned_rad < 0.0) turned_rad = s.true_turned_rad;
    ASSERT_EQ(s.true_turned_rad, turned_rad) << "the true path must not depend on the seed";
  }
  ASSERT_GT(turned_rad, 1.0) << "the path must turn about 90 degrees";
  expectMatchesNormal(err, 0.0, n.sigma_per_rad * std::sqrt(turned_rad), "heading error");
}

TEST(MotionSimulator, WheelBaseErrorScalesTurns) {
  OdometryNoiseSpec n = zeroNoise();
  n.wheel_base_error = 0.05;
  const RobotSpec r = leftTurn();
  const auto samples = run(r, n, 1, framesToFinish(r, 2.0));
  // Start yaw is 0 and the path turns left by less than pi, so yaw is the summed turn.
  ASSERT_GT(samples.back().true_pose.yaw_rad, 1.0);
  for (const MotionSample& s : samples) {
    EXPECT_NEAR(s.odom_pose.yaw_rad, s.true_pose.yaw_rad / (1.0 + n.wheel_base_error), kExactTol);
  }
}

TEST(MotionSimulator, SlipShiftsOdometryOnceAtItsTime) {
  RobotSpec r;
  r.waypoints = {{0.0, 0.0}, {5.0, 0.0}};
  r.loop = false;
  OdometryNoiseSpec n = zeroNoise();
  constexpr int kSlipFrame = 20;
  // At exactly frame 20's time the slip falls into that frame's last substep.
  const SlipEvent slip{kSlipFrame / r.frame_rate_hz, 0.1, -0.05, 0.1};
  n.slips = {slip};
  const auto samples = run(r, n, 1, 40);
  for (int k = 0; k < kSlipFrame; ++k) {
    expectPoseNear(samples[k].odom_pose, samples[k].true_pose, kExactTol, k);
  }
  // Straight run along +x with yaw 0: the body-frame slip is a world-frame shift.
  const Pose2& t = samples[kSlipFrame].true_pose;
  const Pose2& o = samples[kSlipFrame].odom_pose;
  EXPECT_NEAR(o.x_m - t.x_m, slip.dx_m, kExactTol);
  EXPECT_NEAR(o.y_m - t.y_m, slip.dy_m, kExactTol);
  EXPECT_NEAR(o.yaw_rad - t.yaw_rad, slip.dyaw_rad, kExactTol);
  // Applied once: the yaw offset stays, it does not grow.
  for (size_t k = kSlipFrame; k < samples.size(); ++k) {
    EXPECT_NEAR(
        samples[k].odom_pose.yaw_rad - samples[k].true_pose.yaw_rad, slip.dyaw_rad, kExactTol);
  }
  // After the slip, odometry drives on along its rotated heading.
  const double ds = samples[kSlipFrame + 1].true_distance_m - samples[kSlipFrame].true_distance_m;
  EXPECT_NEAR(
      samples[kSlipFrame + 1].odom_pose.x_m, o.x_m + ds * std::cos(slip.dyaw_rad), kExactTol);
  EXPECT_NEAR(
      samples[kSlipFrame + 1].odom_pose.y_m, o.y_m + ds * std::sin(slip.dyaw_rad), kExactTol);
}

TEST(MotionSimulator, SlipBetweenFramesShowsInTheNextFrame) {
  RobotSpec r;
  r.waypoints = {{0.0, 0.0}, {5.0, 0.0}};
  OdometryNoiseSpec n = zeroNoise();
  n.slips = {{10.5 / r.frame_rate_hz, 0.2, 0.0, 0.0}};
  const auto samples = run(r, n, 1, 15);
  EXPECT_NEAR(samples[10].odom_pose.x_m, samples[10].true_pose.x_m, kExactTol);
  EXPECT_NEAR(samples[11].odom_pose.x_m - samples[11].true_pose.x_m, 0.2, kExactTol);
  EXPECT_NEAR(samples[14].odom_pose.x_m - samples[14].true_pose.x_m, 0.2, kExactTol);
}

TEST(MotionSimulator, StartWaypointStartsThereHeadingForTheNext) {
  RobotSpec r = squarePath();
  for (int k = 0; k < 4; ++k) {
    r.start_waypoint = k;
    MotionSimulator sim(r, OdometryNoiseSpec{}, 3, kStartNs);
    const MotionSample s = sim.next();
    const Eigen::Vector2d& p = r.waypoints[static_cast<size_t>(k)];
    const Eigen::Vector2d d = r.waypoints[static_cast<size_t>((k + 1) % 4)] - p;
    EXPECT_EQ(s.true_pose.x_m, p.x()) << "start waypoint " << k;
    EXPECT_EQ(s.true_pose.y_m, p.y()) << "start waypoint " << k;
    EXPECT_NEAR(wrap(s.true_pose.yaw_rad - std::atan2(d.y(), d.x())), 0.0, kExactTol);
    // Odometry starts at the true start pose.
    EXPECT_EQ(s.odom_pose.x_m, s.true_pose.x_m);
    EXPECT_EQ(s.odom_pose.y_m, s.true_pose.y_m);
    EXPECT_EQ(s.odom_pose.yaw_rad, s.true_pose.yaw_rad);
  }
}

TEST(MotionSimulator, StartWaypointZeroIsTheDefault) {
  OdometryNoiseSpec n;
  n.sigma_per_m = 0.05;
  n.sigma_per_rad = 0.05;
  RobotSpec r0 = squarePath();
  r0.start_waypoint = 0;
  const auto a = run(squarePath(), n, 7, 200);
  const auto b = run(r0, n, 7, 200);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].true_pose.x_m, b[k].true_pose.x_m);
    EXPECT_EQ(a[k].true_pose.yaw_rad, b[k].true_pose.yaw_rad);
    EXPECT_EQ(a[k].odom_pose.x_m, b[k].odom_pose.x_m);
    EXPECT_EQ(a[k].odom_pose.y_m, b[k].odom_pose.y_m);
  }
}

TEST(MotionSimulator, StartAtLastWaypointWrapsRoundToTheFirst) {
  RobotSpec r = squarePath();
  r.start_waypoint = 3;  // (0, 3), heading for (0, 0), i.e. -y
  const auto samples = run(r, zeroNoise(), 1, static_cast<int>(8.0 / r.speed_mps * 15.0));
  EXPECT_NEAR(wrap(samples[0].true_pose.yaw_rad + M_PI / 2.0), 0.0, kExactTol);
  // Visits waypoint 0, then waypoint 1 after it (the path goes on past the wrap).
  const double slack_m = r.waypoint_radius_m + r.speed_mps / r.frame_rate_hz;
  size_t reached_0 = 0, reached_1 = 0;
  for (size_t k = 1; k < samples.size(); ++k) {
    const Eigen::Vector2d p(samples[k].true_pose.x_m, samples[k].true_pose.y_m);
    if (reached_0 == 0 && (p - r.waypoints[0]).norm() <= slack_m) reached_0 = k;
    if (reached_0 > 0 && reached_1 == 0 && (p - r.waypoints[1]).norm() <= slack_m) reached_1 = k;
  }
  EXPECT_GT(reached_0, 0u);
  EXPECT_GT(reached_1, reached_0);
}

TEST(MotionSimulator, StartWaypointOfClosedPathSkipsTheRepeatedFirstWaypoint) {
  // The last waypoint repeats the first: starting there heads for waypoint 1.
  RobotSpec r;
  r.waypoints = {{0.0, 0.0}, {2.0, 0.0}, {2.0, 2.0}, {0.0, 0.0}};
  r.start_waypoint = 3;
  MotionSimulator sim(r, zeroNoise(), 1, kStartNs);
  EXPECT_NEAR(sim.next().true_pose.yaw_rad, 0.0, kExactTol);
}

TEST(MotionSimulator, StartWaypointOfNonLoopingPathStopsAtItsLastWaypoint) {
  RobotSpec r = leftTurn();
  r.start_waypoint = 1;  // (1, 0) heading +y, then stops at (1, 1)
  const auto samples = run(r, zeroNoise(), 1, framesToFinish(r, 1.0) + 20);
  EXPECT_NEAR(wrap(samples[0].true_pose.yaw_rad - M_PI / 2.0), 0.0, kExactTol);
  constexpr double kStopTolM = 1e-3;
  EXPECT_NEAR(samples.back().true_pose.x_m, 1.0, kStopTolM);
  EXPECT_NEAR(samples.back().true_pose.y_m, 1.0, kStopTolM);
  EXPECT_NEAR(samples.back().true_distance_m, 1.0, kStopTolM);
}

TEST(MotionSimulator, StartWaypointIsDeterministicForASeed) {
  OdometryNoiseSpec n;
  n.sigma_per_m = 0.05;
  n.sigma_per_rad = 0.05;
  RobotSpec r = squarePath();
  r.start_waypoint = 2;
  const auto a = run(r, n, 11, 200);
  const auto b = run(r, n, 11, 200);
  const auto c = run(r, n, 12, 200);
  bool any_difference = false;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].odom_pose.x_m, b[k].odom_pose.x_m);
    EXPECT_EQ(a[k].odom_pose.yaw_rad, b[k].odom_pose.yaw_rad);
    EXPECT_EQ(a[k].true_pose.x_m, c[k].true_pose.x_m);
    any_difference = any_difference || a[k].odom_pose.x_m != c[k].odom_pose.x_m;
  }
  EXPECT_TRUE(any_difference);
}

TEST(StartWaypointStatus, OutOfRangeNamesValueAndWaypointCount) {
  RobotSpec r = squarePath();
  EXPECT_TRUE(startWaypointStatus(r, 0).isOk());
  EXPECT_TRUE(startWaypointStatus(r, 3).isOk());
  for (int k : {-1, 4, 100}) {
    const Status s = startWaypointStatus(r, k);
    ASSERT_FALSE(s.isOk()) << k;
    EXPECT_NE(s.message().find(std::to_string(k)), std::string::npos) << s.message();
    EXPECT_NE(s.message().find("4 waypoints"), std::string::npos) << s.message();
  }
  // A non-looping path stops at its last waypoint: no start there.
  r.loop = false;
  EXPECT_TRUE(startWaypointStatus(r, 2).isOk());
  EXPECT_FALSE(startWaypointStatus(r, 3).isOk());
  // World::validate() names the key.
  World w;
  w.robot = squarePath();
  w.robot.start_waypoint = 9;
  const Status v = w.validate();
  ASSERT_FALSE(v.isOk());
  EXPECT_NE(v.message().find("robot.start_waypoint 9"), std::string::npos) << v.message();
}

}  // namespace
}  // namespace twocam::sim
