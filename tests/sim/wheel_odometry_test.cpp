#include "sim/wheel_odometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "sim/world_io.h"
#include "support/test_paths.h"

namespace twocam::sim {
namespace {

namespace fs = std::filesystem;

/// Noise-free odometry repeats the arithmetic of integrateIncrement on increments recovered
/// from its own output: equal up to a few ulps of the 10-100 m coordinates.
constexpr double kExactTol = 1e-9;
/// Statistical checks: within this many standard errors of the model (seeded anyway).
constexpr double kStatSigmas = 4.0;
/// Monte Carlo runs: the standard error of a sample standard deviation is then 1.6 % of it.
constexpr int kMonteCarloRuns = 2000;
constexpr double kDegToRad = M_PI / 180.0;
constexpr int64_t kFramePeriodNs = 100'000'000;  // KITTI's 10 Hz

OdometryNoiseSpec zeroNoise() {
  OdometryNoiseSpec n;
  n.sigma_per_m = 0.0;
  n.sigma_per_rad = 0.0;
  n.scale_error = 0.0;
  n.wheel_base_error = 0.0;
  return n;
}

double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }

/// A recorded-looking trajectory: n frames at 10 Hz, 1.2 m per frame (a car at 12 m/s) on a
/// gentle left curve made with integrateIncrement, so that planarIncrement recovers it exactly.
struct Track {
  std::vector<int64_t> t_ns;
  std::vector<Pose2> truth;
  std::vector<Eigen::Isometry3d> T_w_b;
};
Track curve(int n, double ds_m = 1.2, double dyaw_rad = 0.01) {
  Track t;
  Pose2 p{3.0, -2.0, 0.4};
  for (int k = 0; k < n; ++k) {
    if (k > 0) p = integrateIncrement(p, ds_m, dyaw_rad);
    t.t_ns.push_back(k * kFramePeriodNs);
    t.truth.push_back(p);
    t.T_w_b.push_back(toIsometry(p));
  }
  return t;
}

TEST(PlanarIncrement, InvertsIntegrateIncrementOverSeededTrials) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> xy(-50.0, 50.0), yaw(-M_PI, M_PI), ds(-3.0, 3.0),
      dyaw(-1.0, 1.0);
  for (int trial = 0; trial < 1000; ++trial) {
    const Pose2 from{xy(rng), xy(rng), yaw(rng)};
    const double want_ds = ds(rng);
    const double want_dyaw = dyaw(rng);
    double got_ds = 0.0;
    double got_dyaw = 0.0;
    planarIncrement(from, integrateIncrement(from, want_ds, want_dyaw), &got_ds, &got_dyaw);
    ASSERT_NEAR(got_ds, want_ds, kExactTol) << "trial " << trial;
    ASSERT_NEAR(got_dyaw, want_dyaw, kExactTol) << "trial " << trial;
  }
}

TEST(PlanarPose, ProjectsTheBodyXAxisOntoTheFloor) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  // Yaw 0.5, then pitched nose-down by 0.2 and rolled: the heading stays 0.5.
  T.linear() = (Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()))
                   .matrix();
  T.translation() = Eigen::Vector3d(1.0, 2.0, 3.0);
  const Pose2 p = planarPose(T);
  EXPECT_NEAR(p.x_m, 1.0, kExactTol);
  EXPECT_NEAR(p.y_m, 2.0, kExactTol);
  EXPECT_NEAR(p.yaw_rad, 0.5, kExactTol);
}

TEST(SyntheticOdometry, ZeroNoiseEqualsTruth) {
  const Track t = curve(51);
  const auto odo = syntheticOdometry(t.t_ns, t.T_w_b, zeroNoise(), 1);
  ASSERT_EQ(odo.size(), t.truth.size());
  for (size_t k = 0; k < odo.size(); ++k) {
    EXPECT_NEAR(odo[k].x_m, t.truth[k].x_m, kExactTol) << k;
    EXPECT_NEAR(odo[k].y_m, t.truth[k].y_m, kExactTol) << k;
    EXPECT_NEAR(wrap(odo[k].yaw_rad - t.truth[k].yaw_rad), 0.0, kExactTol) << k;
  }
}

TEST(SyntheticOdometry, SameSeedSameOutputDifferentSeedDifferentOutput) {
  const Track t = curve(51);
  OdometryNoiseSpec n;
  n.sigma_per_m = 0.06;
  n.sigma_per_rad = 0.09;
  n.scale_error = 0.03;
  n.wheel_base_error = 0.03;
  const auto a = syntheticOdometry(t.t_ns, t.T_w_b, n, 1);
  const auto b = syntheticOdometry(t.t_ns, t.T_w_b, n, 1);
  const auto c = syntheticOdometry(t.t_ns, t.T_w_b, n, 2);
  bool any_difference = false;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].x_m, b[k].x_m) << k;
    EXPECT_EQ(a[k].y_m, b[k].y_m) << k;
    EXPECT_EQ(a[k].yaw_rad, b[k].yaw_rad) << k;
    any_difference = any_difference || a[k].x_m != c[k].x_m || a[k].yaw_rad != c[k].yaw_rad;
  }
  EXPECT_TRUE(any_difference) << "seed 2 gave seed 1's odometry";
  EXPECT_EQ(a[0].x_m, t.truth[0].x_m) << "frame 0's odometry is the start pose";
}

// A slip changes the odometry from the frame at its time on, by exactly its offset in the body
// frame of that moment, and not before.
TEST(SyntheticOdometry, SlipsShowUpAtTheirTime) {
  const Track t = curve(51, 1.2, 0.0);  // straight: the offset stays the same afterwards
  OdometryNoiseSpec n = zeroNoise();
  n.slips = {{1.5, 0.10, 0.0, 0.0}, {3.5, 0.0, 0.0, 3.0 * kDegToRad}};
  const auto odo = syntheticOdometry(t.t_ns, t.T_w_b, n, 1);
  const double c = std::cos(t.truth[0].yaw_rad);
  const double s = std::sin(t.truth[0].yaw_rad);
  for (size_t k = 0; k < odo.size(); ++k) {
    const double along = (odo[k].x_m - t.truth[k].x_m) * c + (odo[k].y_m - t.truth[k].y_m) * s;
    const double dyaw = wrap(odo[k].yaw_rad - t.truth[k].yaw_rad);
    if (k < 15) {
      EXPECT_NEAR(along, 0.0, kExactTol) << "before the 1.5 s slip, frame " << k;
    } else if (k < 35) {
      EXPECT_NEAR(along, 0.10, kExactTol) << "after the 1.5 s slip, frame " << k;
      EXPECT_NEAR(dyaw, 0.0, kExactTol) << k;
    } else {
      EXPECT_NEAR(dyaw, 3.0 * kDegToRad, kExactTol) << "after the 3.5 s slip, frame " << k;
    }
  }
}

TEST(SyntheticOdometry, ScaleAndWheelBaseErrorsBiasExactly) {
  const Track t = curve(11, 1.0, 0.05);
  OdometryNoiseSpec n = zeroNoise();
  n.scale_error = 0.03;
  n.wheel_base_error = 0.25;
  const auto odo = syntheticOdometry(t.t_ns, t.T_w_b, n, 1);
  // Turned 10 x 0.05 rad truly, reported / 1.25.
  EXPECT_NEAR(wrap(odo.back().yaw_rad - odo.front().yaw_rad), 0.5 / 1.25, kExactTol);
}

// The random walk has the model's spread whatever the increments: sigma_per_m sqrt(distance).
TEST(SyntheticOdometry, DistanceRandomWalkHasModelStd) {
  const Track t = curve(11, 1.2, 0.0);  // 12 m straight
  OdometryNoiseSpec n = zeroNoise();
  n.sigma_per_m = 0.06;
  std::vector<double> err;
  const double c = std::cos(t.truth[0].yaw_rad);
  const double s = std::sin(t.truth[0].yaw_rad);
  for (int seed = 0; seed < kMonteCarloRuns; ++seed) {
    const auto odo = syntheticOdometry(t.t_ns, t.T_w_b, n, static_cast<uint64_t>(seed));
    err.push_back((odo.back().x_m - t.truth.back().x_m) * c +
                  (odo.back().y_m - t.truth.back().y_m) * s);
  }
  double mean = 0.0;
  for (double e : err) mean += e;
  mean /= kMonteCarloRuns;
  double ss = 0.0;
  for (double e : err) ss += (e - mean) * (e - mean);
  const double std = std::sqrt(ss / (kMonteCarloRuns - 1));
  const double model = n.sigma_per_m * std::sqrt(12.0);
  EXPECT_NEAR(mean, 0.0, kStatSigmas * model / std::sqrt(kMonteCarloRuns));
  EXPECT_NEAR(std, model, kStatSigmas * model / std::sqrt(2.0 * (kMonteCarloRuns - 1)));
}

void writeFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

// The noise file's section reads as the world file's does: office.yaml's own section, cut out
// into a file, gives the world's spec.
TEST(OdometryNoiseFile, ReadsAWorldFilesSectionIdentically) {
  const std::string office = test::sourceDir() + "/worlds/office.yaml";
  World world;
  ASSERT_TRUE(loadWorld(office, &world).isOk());
  std::ifstream in(office);
  std::string line;
  std::string section;
  bool inside = false;
  while (std::getline(in, line)) {
    if (line.rfind("odometry_noise:", 0) == 0)
      inside = true;
    else if (inside && !line.empty() && line[0] != ' ')
      break;
    if (inside) section += line + "\n";
  }
  ASSERT_FALSE(section.empty());
  const std::string dir = test::makeTempDir("odometry_noise_file");
  writeFile(dir + "/noise.yaml", section);
  OdometryNoiseSpec n;
  const Status st = loadOdometryNoise(dir + "/noise.yaml", &n);
  ASSERT_TRUE(st.isOk()) << st.message();
  const OdometryNoiseSpec& w = world.odometry_noise;
  EXPECT_EQ(n.sigma_per_m, w.sigma_per_m);
  EXPECT_EQ(n.sigma_per_rad, w.sigma_per_rad);
  EXPECT_EQ(n.scale_error, w.scale_error);
  EXPECT_EQ(n.wheel_base_error, w.wheel_base_error);
  ASSERT_EQ(n.slips.size(), w.slips.size());
  EXPECT_EQ(n.slips[0].time_s, w.slips[0].time_s);
  EXPECT_EQ(n.slips[0].dyaw_rad, w.slips[0].dyaw_rad);
}

TEST(OdometryNoiseFile, ShippedKittiConfigIsOfficeTimesThreeWithTwoSlips) {
  World world;
  ASSERT_TRUE(loadWorld(test::sourceDir() + "/worlds/office.yaml", &world).isOk());
  OdometryNoiseSpec n;
  const Status st = loadOdometryNoise(test::sourceDir() + "/configs/kitti_odometry_noise.yaml", &n);
  ASSERT_TRUE(st.isOk()) << st.message();
  const OdometryNoiseSpec x3 = scaledOdometryNoise(world.odometry_noise, 3.0);
  EXPECT_NEAR(n.sigma_per_m, x3.sigma_per_m, kExactTol);
  EXPECT_NEAR(n.sigma_per_rad, x3.sigma_per_rad, kExactTol);
  EXPECT_NEAR(n.scale_error, x3.scale_error, kExactTol);
  EXPECT_NEAR(n.wheel_base_error, x3.wheel_base_error, kExactTol);
  ASSERT_EQ(n.slips.size(), 2u);
  EXPECT_EQ(n.slips[0].time_s, 1.5);
  EXPECT_NEAR(n.slips[0].dx_m, 0.10, kExactTol);
  EXPECT_EQ(n.slips[1].time_s, 3.5);
  EXPECT_NEAR(n.slips[1].dyaw_rad, 3.0 * kDegToRad, kExactTol);
}

TEST(OdometryNoiseFile, ErrorsNameTheFileAndTheKey) {
  const std::string dir = test::makeTempDir("odometry_noise_errors");
  const std::string path = dir + "/noise.yaml";
  OdometryNoiseSpec n;
  const auto expect_error = [&](const std::string& text, const std::string& what) {
    writeFile(path, text);
    const Status st = loadOdometryNoise(path, &n);
    ASSERT_FALSE(st.isOk()) << text;
    EXPECT_NE(st.message().find("'" + path + "'"), std::string::npos) << st.message();
    EXPECT_NE(st.message().find(what), std::string::npos)
        << "expected '" << what << "' in: " << st.message();
  };
  expect_error("odometry_noise:\n  sigma_per_m: 0.1\n  scale_eror: 0.1\n",
               "unknown key 'odometry_noise.scale_eror' (line 3); did you mean "
               "'odometry_noise.scale_error'?");
  expect_error("odometry_noise:\n  slips: [{time_s: 1, dz_m: 0.1}]\n",
               "unknown key 'odometry_noise.slips[0].dz_m'");
  expect_error("seed: 3\nodometry_noise: {}\n", "unknown key 'seed'");
  expect_error("# nothing\n", "empty");
  expect_error("other: 1\n", "unknown key 'other'");
  expect_error("odometry_noise:\n  sigma_per_m: -0.1\n",
               "odometry_noise.sigma_per_m = -0.1: must be >= 0");
  expect_error("odometry_noise:\n  slips: [{time_s: -1}]\n",
               "odometry_noise.slips[0].time_s = -1: must be >= 0");
  expect_error("odometry_noise:\n  sigma_per_m: [1, 2]\n", "must be a number");
  const Status missing = loadOdometryNoise(dir + "/absent.yaml", &n);
  ASSERT_FALSE(missing.isOk());
  EXPECT_NE(missing.message().find("absent.yaml': no such file"), std::string::npos)
      << missing.message();

  // Absent keys keep a world file's defaults.
  writeFile(path, "odometry_noise:\n  scale_error: 0.02\n");
  ASSERT_TRUE(loadOdometryNoise(path, &n).isOk());
  EXPECT_EQ(n.scale_error, 0.02);
  EXPECT_EQ(n.sigma_per_m, World().odometry_noise.sigma_per_m);
  EXPECT_TRUE(n.slips.empty());
}

}  // namespace
}  // namespace twocam::sim
