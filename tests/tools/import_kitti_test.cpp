// `twocam import-kitti`: runs the built binary on the shared KITTI excerpt (skipped when
// ../shared/data is absent) and on broken copies of it, and reads the imported log back.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "io/rawlog.h"
#include "support/command.h"
#include "support/test_paths.h"

namespace twocam {
namespace {

namespace fs = std::filesystem;

// kitti_seq_a: -P1[0][3] / P1[0][0] = 379.8145 / 707.0912 m; rig values go through the log as
// doubles.
constexpr double kBaselineM = 0.537150;
constexpr double kBaselineTolM = 1e-5;
// Its ground-truth path length as measured (59.86 m) and a tolerance for the 7-digit poses.
constexpr double kPathM = 59.86;
constexpr double kPathTolM = 0.05;
// Poses go through the log as doubles (CPose3D): rounding only.
constexpr double kPoseTol = 1e-9;

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout
  std::string error;   // stderr
};

using test::readFile;

RunResult run(const std::string& args) {
  const test::CommandResult c = test::runCommand(std::string(TWOCAM_BINARY) + " " + args);
  return {c.exit_code, c.out, c.err};
}

std::string noiseFile() { return test::sourceDir() + "/configs/kitti_odometry_noise.yaml"; }

/// Expects a one-line "twocam import-kitti: error: ..." containing `text`, exit code 1.
void expectError(const RunResult& r, const std::string& text) {
  EXPECT_EQ(r.exit_code, 1) << r.output << r.error;
  EXPECT_EQ(r.error.rfind("twocam import-kitti: error: ", 0), 0u) << r.error;
  EXPECT_EQ(std::count(r.error.begin(), r.error.end(), '\n'), 1) << r.error;
  EXPECT_NE(r.error.find(text), std::string::npos) << "expected '" << text << "' in: " << r.error;
}

/// A writable copy of the excerpt's first n pairs with its calib.txt and first n poses: DIR/seq.
std::string copySequence(const std::string& seq_a, const std::string& dir, int n) {
  const fs::path seq = fs::path(dir) / "seq";
  for (const char* cam : {"image_l", "image_r"}) {
    fs::create_directories(seq / cam);
    for (int k = 0; k < n; ++k) {
      char name[32];
      std::snprintf(name, sizeof(name), "%06d.png", k);
      fs::copy_file(fs::path(seq_a) / cam / name, seq / cam / name);
    }
  }
  fs::copy_file(fs::path(seq_a) / "calib.txt", seq / "calib.txt");
  std::ifstream in(fs::path(seq_a) / "poses.txt");
  std::ofstream out(seq / "poses.txt");
  std::string line;
  for (int k = 0; k < n && std::getline(in, line); ++k) out << line << "\n";
  for (const auto& e : fs::recursive_directory_iterator(seq))
    fs::permissions(e.path(), fs::perms::owner_all, fs::perm_options::add);
  return seq.string();
}

struct LogContents {
  std::vector<io::LogFrame> frames;  // images dropped after the size check
  StereoRig rig;
  std::optional<std::string> synthetic;
};

LogContents readLog(const std::string& path) {
  LogContents out;
  std::unique_ptr<io::RawlogReader> reader;
  const Status st = io::RawlogReader::open(path, &reader);
  EXPECT_TRUE(st.isOk()) << st.message();
  if (!st) return out;
  out.rig = reader->rig();
  out.synthetic = reader->syntheticOdometry();
  io::LogFrame f;
  Status rs;
  while (reader->next(&f, &rs)) {
    EXPECT_EQ(f.stereo.left.width, out.rig.width_px);
    EXPECT_EQ(f.stereo.right.height, out.rig.height_px);
    f.stereo.left = ImageU8();
    f.stereo.right = ImageU8();
    out.frames.push_back(f);
  }
  EXPECT_TRUE(rs.isOk()) << rs.message();
  return out;
}

TEST(ImportKitti, HelpListsTheCommand) {
  const RunResult r = run("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("import-kitti"), std::string::npos);
  const RunResult h = run("import-kitti --help");
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.output.find("--synthetic-odometry"), std::string::npos);
  EXPECT_NE(h.output.find("--seed"), std::string::npos);
}

// The whole excerpt with synthetic odometry: 51 frames at 10 Hz with ground truth (first pose
// the identity, ~59.9 m driven along body x) and odometry marked synthetic; the same seed gives
// the same odometry, another seed another; without the option the log has no odometry.
TEST(ImportKitti, ImportsTheSharedSequenceWithSyntheticOdometry) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string seq = data + "/kitti_seq_a";
  const std::string dir = test::makeTempDir("import_kitti_seq_a");
  const std::string log = dir + "/kitti.rawlog";
  const RunResult r = run("import-kitti " + seq + " -o " + log + " --synthetic-odometry " +
                          noiseFile() + " --seed 1");
  ASSERT_EQ(r.exit_code, 0) << r.output << r.error;
  std::cout << r.output;
  EXPECT_NE(r.error.find("import-kitti"), std::string::npos) << "progress bar expected on stderr";
  EXPECT_NE(r.output.find("imported 51 of 51"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("odometry: SYNTHETIC"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(log + ".partial"));

  const LogContents a = readLog(log);
  ASSERT_EQ(a.frames.size(), 51u);
  EXPECT_EQ(a.rig.width_px, 1226);
  EXPECT_EQ(a.rig.height_px, 370);
  EXPECT_NEAR(a.rig.baseline_m, kBaselineM, kBaselineTolM);
  ASSERT_TRUE(a.synthetic.has_value());
  EXPECT_NE(a.synthetic->find("seed 1"), std::string::npos) << *a.synthetic;
  EXPECT_NE(a.synthetic->find("kitti_odometry_noise.yaml"), std::string::npos) << *a.synthetic;
  EXPECT_NE(a.synthetic->find("scale_error 0.03"), std::string::npos)
      << "the header holds the effective model: " << *a.synthetic;
  EXPECT_NE(a.synthetic->find("[1.5 0.1 0 0; 3.5 0 0 3]"), std::string::npos) << *a.synthetic;
  double path_m = 0.0;
  for (size_t k = 0; k < a.frames.size(); ++k) {
    const io::LogFrame& f = a.frames[k];
    EXPECT_EQ(f.stereo.t_ns, static_cast<int64_t>(k) * 100'000'000) << k;
    ASSERT_TRUE(f.odometry.has_value()) << k;
    EXPECT_TRUE(f.odometry_synthetic) << k;
    ASSERT_TRUE(f.ground_truth.has_value()) << k;
    EXPECT_TRUE(f.ground_truth->depth_left.empty()) << "KITTI's log has no true depth";
    if (k > 0) {
      path_m +=
          (f.ground_truth->T_w_b.translation() - a.frames[k - 1].ground_truth->T_w_b.translation())
              .norm();
    }
  }
  EXPECT_TRUE(a.frames[0].ground_truth->T_w_b.isApprox(Eigen::Isometry3d::Identity(), kPoseTol));
  EXPECT_NEAR(path_m, kPathM, kPathTolM);
  EXPECT_GT(a.frames.back().ground_truth->T_w_b.translation().x(), 55.0);
  // Odometry starts at the truth and, with 3 % scale error and two slips, ends off it.
  EXPECT_EQ(a.frames[0].odometry->pose.x_m, 0.0);
  const Pose2& last = a.frames.back().odometry->pose;
  const Eigen::Vector3d truth = a.frames.back().ground_truth->T_w_b.translation();
  EXPECT_GT(std::hypot(last.x_m - truth.x(), last.y_m - truth.y()), 0.5);

  const std::string log_b = dir + "/same_seed.rawlog";
  const std::string log_c = dir + "/other_seed.rawlog";
  ASSERT_EQ(run("import-kitti " + seq + " -o " + log_b + " --synthetic-odometry " + noiseFile() +
                " --seed 1 -q")
                .exit_code,
            0);
  ASSERT_EQ(run("import-kitti " + seq + " -o " + log_c + " --synthetic-odometry " + noiseFile() +
                " --seed 2 -q")
                .exit_code,
            0);
  const LogContents b = readLog(log_b);
  const LogContents c = readLog(log_c);
  ASSERT_EQ(b.frames.size(), 51u);
  ASSERT_EQ(c.frames.size(), 51u);
  bool any_difference = false;
  for (size_t k = 0; k < a.frames.size(); ++k) {
    EXPECT_EQ(a.frames[k].odometry->pose.x_m, b.frames[k].odometry->pose.x_m) << k;
    EXPECT_EQ(a.frames[k].odometry->pose.yaw_rad, b.frames[k].odometry->pose.yaw_rad) << k;
    any_difference =
        any_difference || a.frames[k].odometry->pose.x_m != c.frames[k].odometry->pose.x_m;
  }
  EXPECT_TRUE(any_difference) << "--seed 2 gave --seed 1's odometry";

  const std::string plain = dir + "/plain.rawlog";
  const RunResult p = run("import-kitti " + seq + " -o " + plain + " --max-frames 5 -q");
  ASSERT_EQ(p.exit_code, 0) << p.error;
  EXPECT_TRUE(p.error.empty()) << "--quiet: no progress bar, got: " << p.error;
  EXPECT_NE(p.output.find("imported 5 of 51"), std::string::npos) << p.output;
  EXPECT_NE(p.output.find("odometry: none"), std::string::npos) << p.output;
  const LogContents q = readLog(plain);
  ASSERT_EQ(q.frames.size(), 5u);
  EXPECT_FALSE(q.synthetic.has_value());
  for (const io::LogFrame& f : q.frames) {
    EXPECT_FALSE(f.odometry.has_value());
    EXPECT_TRUE(f.ground_truth.has_value());
  }
}

// `twocam run` on an import says the odometry is synthetic (summary and metrics.json) and runs
// the landmark database on it; on an import without odometry it runs the frontend only.
TEST(ImportKitti, RunSaysTheOdometryIsSynthetic) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string seq = data + "/kitti_seq_a";
  const std::string dir = test::makeTempDir("import_kitti_run");
  // 20 frames at 10 Hz: the noise file's slip at 1.5 s lands on frame 15, the one at 3.5 s
  // after the end.
  ASSERT_EQ(run("import-kitti " + seq + " -o " + dir + "/syn.rawlog --max-frames 20 -q" +
                " --synthetic-odometry " + noiseFile())
                .exit_code,
            0);
  EXPECT_EQ(readFile(dir + "/syn.slips.csv"),
            "frame,time_s,dx_m,dy_m,dyaw_deg\n15,1.5,0.1,0,0\n-1,3.5,0,0,3\n");
  // A slips file beside an earlier log at the path no longer describes the new one.
  std::ofstream(dir + "/plain.slips.csv") << "frame,time_s,dx_m,dy_m,dyaw_deg\n1,0.1,0.1,0,0\n";
  ASSERT_EQ(run("import-kitti " + seq + " -o " + dir + "/plain.rawlog --max-frames 8 -q").exit_code,
            0);
  EXPECT_FALSE(fs::exists(dir + "/plain.slips.csv"));
  const RunResult r = run("run " + dir + "/syn.rawlog -o " + dir + "/syn_run -q --no-pictures");
  ASSERT_EQ(r.exit_code, 0) << r.output << r.error;
  EXPECT_NE(r.output.find("odometry: SYNTHETIC (drawn from the ground truth"), std::string::npos)
      << r.output;
  const std::string metrics = readFile(dir + "/syn_run/metrics.json");
  EXPECT_NE(metrics.find("\"odometry\": true"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("\"odometry_synthetic\": true"), std::string::npos) << metrics;
  // True poses without true depth: the trajectory is measured and the landmarks are judged by the
  // true motion (METRICS.md landmarks.true_pose_consistency); no depth-based verdicts.
  for (const char* key : {"\"ground_truth_poses\": true",
                          "\"ground_truth\": false",
                          "\"ate_rmse_m\"",
                          "\"rpe_trans_pct\"",
                          "\"true_pose_consistency\"",
                          "\"true_pose_judged\""}) {
    EXPECT_NE(metrics.find(key), std::string::npos) << key << "\n" << metrics;
  }
  // Slip detection against the slips file: one slip inside the log.
  EXPECT_NE(metrics.find("\"source\": \"" + dir + "/syn.slips.csv\""), std::string::npos)
      << metrics;
  EXPECT_NE(metrics.find("\"true\": 1"), std::string::npos) << metrics;
  EXPECT_EQ(readFile(dir + "/syn_run/slip_events.csv"), readFile(dir + "/syn.slips.csv"));
  // A broken slips file: the run goes on, says so, and reports the slips as absent.
  std::ofstream(dir + "/syn.slips.csv") << "frame,time_s,dx_m,dy_m,dyaw_deg\n15,x,0,0,0\n";
  const RunResult b = run("run " + dir + "/syn.rawlog -o " + dir + "/bad_run -q --no-pictures");
  ASSERT_EQ(b.exit_code, 0) << b.output << b.error;
  EXPECT_NE(b.error.find("no slip metrics: " + dir + "/syn.slips.csv:2: 'x' is not a finite"),
            std::string::npos)
      << b.error;
  EXPECT_NE(readFile(dir + "/bad_run/metrics.json").find("\"slips\": {\"absent\""),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir + "/bad_run/slip_events.csv"));
  EXPECT_TRUE(fs::exists(dir + "/syn_run/trajectory_gt.tum"));
  EXPECT_TRUE(fs::exists(dir + "/syn_run/trajectory_est.tum"));

  const RunResult p = run("run " + dir + "/plain.rawlog -o " + dir + "/plain_run -q --no-pictures");
  ASSERT_EQ(p.exit_code, 0) << p.output << p.error;
  EXPECT_EQ(p.output.find("SYNTHETIC"), std::string::npos) << p.output;
  EXPECT_NE(p.error.find("has no odometry: running the frontend only"), std::string::npos)
      << p.error;
  const std::string plain_metrics = readFile(dir + "/plain_run/metrics.json");
  EXPECT_NE(plain_metrics.find("\"odometry\": false"), std::string::npos) << plain_metrics;
  EXPECT_NE(plain_metrics.find("\"odometry_synthetic\": false"), std::string::npos)
      << plain_metrics;
}

// Every error: one line, exit 1, no log and no partial files; an earlier log at the output path
// and its images survive untouched.
TEST(ImportKitti, ErrorsLeaveNoLogAndKeepAnEarlierOne) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string seq_a = data + "/kitti_seq_a";
  const std::string dir = test::makeTempDir("import_kitti_errors");
  const std::string log = dir + "/out.rawlog";
  const std::string images = dir + "/out_Images";
  {
    const std::string good = copySequence(seq_a, dir + "/good", 2);
    const RunResult r = run("import-kitti " + good + " -o " + log + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.output << r.error;
  }
  const std::string log_bytes = readFile(log);
  const std::string image_bytes = readFile(images + "/left_000001.png");
  ASSERT_FALSE(log_bytes.empty());
  ASSERT_FALSE(image_bytes.empty());
  auto expect_untouched = [&](const std::string& what) {
    EXPECT_EQ(readFile(log), log_bytes) << what << ": the earlier log changed";
    EXPECT_EQ(readFile(images + "/left_000001.png"), image_bytes)
        << what << ": the earlier images changed";
    EXPECT_FALSE(fs::exists(log + ".partial")) << what;
    EXPECT_FALSE(fs::exists(images + ".partial")) << what;
  };
  const std::string opts = " -o " + log + " -q";

  expectError(run("import-kitti " + dir + "/no_such_folder" + opts), "does not exist");
  expect_untouched("missing folder");

  fs::create_directories(dir + "/empty");
  expectError(run("import-kitti " + dir + "/empty" + opts), "is not a KITTI sequence");
  expect_untouched("not a sequence");

  {
    const std::string seq = copySequence(seq_a, dir + "/no_image", 3);
    fs::remove(seq + "/image_r/000001.png");
    expectError(run("import-kitti " + seq + opts), seq + "/image_r/000001.png is missing");
    expect_untouched("missing image");
  }
  {
    const std::string seq = copySequence(seq_a, dir + "/few_poses", 3);
    std::ifstream in(seq_a + "/poses.txt");
    std::ofstream out(seq + "/poses.txt", std::ios::trunc);
    std::string line;
    std::getline(in, line);
    out << line << "\n";
    out.close();
    expectError(run("import-kitti " + seq + opts), seq + "/poses.txt has 1 line but 3 are needed");
    expect_untouched("wrong pose count");
  }
  {
    const std::string seq = copySequence(seq_a, dir + "/bad_calib", 2);
    std::ofstream(seq + "/calib.txt", std::ios::trunc) << "P0: 1 2 3\n";
    expectError(run("import-kitti " + seq + opts), seq + "/calib.txt:1: P0: expected 12 numbers");
    expect_untouched("bad calib.txt");
  }
  {
    // The second pair's right image is corrupt: one frame is written before the error.
    const std::string seq = copySequence(seq_a, dir + "/corrupt_image", 2);
    std::ofstream(seq + "/image_r/000001.png", std::ios::binary | std::ios::trunc) << "not a png";
    const RunResult r = run("import-kitti " + seq + opts);
    expectError(r, "frame 1");
    EXPECT_NE(r.error.find("000001.png"), std::string::npos) << r.error;
    expect_untouched("corrupt image");
  }
  {
    const std::string good = dir + "/good/seq";
    std::ofstream(dir + "/bad_noise.yaml") << "odometry_noise:\n  sigma_per_n: 0.1\n";
    expectError(
        run("import-kitti " + good + opts + " --synthetic-odometry " + dir + "/bad_noise.yaml"),
        "unknown key 'odometry_noise.sigma_per_n'");
    expect_untouched("bad noise file");
    expectError(run("import-kitti " + good + opts + " --seed 4"), "--seed 4 needs");
    expect_untouched("--seed alone");
    fs::remove(good + "/poses.txt");
    expectError(run("import-kitti " + good + opts + " --synthetic-odometry " + noiseFile()),
                "has no poses.txt");
    expect_untouched("synthetic odometry without ground truth");
    expectError(run("import-kitti " + good + " -o " + dir + " -q"), "is a folder");
    expectError(run("import-kitti " + good + " -o " + dir + "/no_such_folder/out.rawlog -q"),
                "does not exist");
    expect_untouched("unwritable output");
  }
}

}  // namespace
}  // namespace twocam
