#include "io/kitti.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "support/test_paths.h"

namespace twocam::io {
namespace {

namespace fs = std::filesystem;

// Values are parsed from decimal text into doubles; poses are re-orthonormalised on load and
// the test writes them with 12 digits: entries move by ~1e-12.
constexpr double kParseTol = 1e-9;
// kitti_seq_a's baseline: -P1[0][3] / P1[0][0] = 379.8145 / 707.0912 m.
constexpr double kSeqABaselineM = 0.537150;
constexpr double kSeqABaselineTolM = 1e-5;
// Path length of kitti_seq_a's ground truth (sum of the 50 steps), as measured: 59.86 m.
constexpr double kSeqAPathM = 59.86;
constexpr double kSeqAPathTolM = 0.05;

constexpr int kWidth = 40;
constexpr int kHeight = 24;

// KITTI's values for sequence 00 (fx = 718.856, baseline 0.54 m) scaled to a tiny image.
constexpr double kFx = 35.0;
constexpr double kCx = 19.5;
constexpr double kCy = 11.5;
constexpr double kBaselineM = 0.54;

std::string row(const Eigen::Matrix<double, 3, 4>& M) {
  std::string out;
  char buf[64];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buf, sizeof(buf), "%s%.12e", out.empty() ? "" : " ", M(r, c));
      out += buf;
    }
  return out;
}

Eigen::Matrix<double, 3, 4> projection(double tx) {
  Eigen::Matrix<double, 3, 4> P;
  P << kFx, 0, kCx, tx, 0, kFx, kCy, 0, 0, 0, 1, 0;
  return P;
}

std::string calibText(bool named) {
  const std::string p0 = row(projection(0.0));
  const std::string p1 = row(projection(-kFx * kBaselineM));
  const std::string p2 = row(projection(46.0));
  if (named) {
    return "P0: " + p0 + "\nP1: " + p1 + "\nP2: " + p2 + "\nP3: " + p2 + "\nTr: " + p0 + "\n";
  }
  return p0 + "\n" + p1 + "\n";
}

void writeFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

std::string poseLine(const Eigen::Isometry3d& T) { return row(T.matrix().topRows<3>()); }

/// A KITTI folder with n grey pairs, calib.txt and poses.txt (camera k at T_w_cam0[k]).
std::string makeSequence(const std::string& name,
                         const std::vector<Eigen::Isometry3d>& T_w_cam0,
                         bool named_calib = true,
                         bool short_names = false) {
  const fs::path dir = fs::path(test::makeTempDir(name)) / "seq";
  const fs::path left = dir / (short_names ? "image_l" : "image_0");
  const fs::path right = dir / (short_names ? "image_r" : "image_1");
  fs::create_directories(left);
  fs::create_directories(right);
  for (size_t k = 0; k < T_w_cam0.size(); ++k) {
    char file[32];
    std::snprintf(file, sizeof(file), "%06zu.png", k);
    const cv::Mat img(kHeight, kWidth, CV_8UC1, cv::Scalar(static_cast<double>(10 * k)));
    EXPECT_TRUE(cv::imwrite((left / file).string(), img));
    EXPECT_TRUE(cv::imwrite((right / file).string(), img));
  }
  writeFile(dir / "calib.txt", calibText(named_calib));
  std::string poses;
  for (size_t k = 0; k < T_w_cam0.size(); ++k) {
    poses += poseLine(T_w_cam0[k]);
    if (k + 1 < T_w_cam0.size()) poses += "\n";  // the last line lacks its newline, as in KITTI
  }
  writeFile(dir / "poses.txt", poses);
  return dir.string();
}

/// Camera poses of a car driving straight ahead along the camera's z axis, 1 m per frame.
std::vector<Eigen::Isometry3d> forward(int n) {
  std::vector<Eigen::Isometry3d> out;
  for (int k = 0; k < n; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(0.0, 0.0, 1.0 * k);
    out.push_back(T);
  }
  return out;
}

Status load(const std::string& dir, KittiSequence* seq, std::optional<int> max_frames = {}) {
  KittiReadOptions options;
  options.max_frames = max_frames;
  return loadKittiSequence(dir, seq, options);
}

void expectError(const Status& st, const std::string& text) {
  ASSERT_FALSE(st.isOk()) << "expected an error containing '" << text << "'";
  EXPECT_NE(st.message().find(text), std::string::npos)
      << "expected '" << text << "' in: " << st.message();
}

TEST(Kitti, ReadsBothCalibrationFormsIntoTheRectifiedRig) {
  for (const bool named : {true, false}) {
    const std::string dir = makeSequence(named ? "kitti_named" : "kitti_bare", forward(3), named);
    KittiSequence seq;
    const Status st = load(dir, &seq);
    ASSERT_TRUE(st.isOk()) << st.message();
    EXPECT_EQ(seq.rig.width_px, kWidth);
    EXPECT_EQ(seq.rig.height_px, kHeight);
    EXPECT_NEAR(seq.rig.fx_px, kFx, kParseTol);
    EXPECT_NEAR(seq.rig.fy_px, kFx, kParseTol);
    EXPECT_NEAR(seq.rig.cx_px, kCx, kParseTol);
    EXPECT_NEAR(seq.rig.cy_px, kCy, kParseTol);
    EXPECT_NEAR(seq.rig.baseline_m, kBaselineM, kParseTol) << (named ? "named" : "bare");
    EXPECT_TRUE(seq.rig.T_b_cl.isApprox(kittiBodyFromLeftCamera()));
    EXPECT_EQ(seq.pairs_available, 3);
    ASSERT_EQ(seq.left_paths.size(), 3u);
    EXPECT_EQ(fs::path(seq.left_paths[2]).filename(), "000002.png");
    EXPECT_EQ(fs::path(seq.right_paths[2]).parent_path().filename(), "image_1");
  }
}

TEST(Kitti, AcceptsImageLAndImageRAndDefaultsToTenHertz) {
  const std::string dir = makeSequence("kitti_lr", forward(4), true, /*short_names=*/true);
  KittiSequence seq;
  ASSERT_TRUE(load(dir, &seq).isOk());
  EXPECT_EQ(fs::path(seq.left_dir).filename(), "image_l");
  EXPECT_EQ(fs::path(seq.right_dir).filename(), "image_r");
  EXPECT_FALSE(seq.has_times);
  EXPECT_EQ(seq.t_ns, (std::vector<int64_t>{0, 100'000'000, 200'000'000, 300'000'000}));
}

TEST(Kitti, ReadsTimesTxt) {
  const std::string dir = makeSequence("kitti_times", forward(3));
  writeFile(fs::path(dir) / "times.txt", "0.000000e+00\n1.037359e-01\n2.073880e-01\n");
  KittiSequence seq;
  const Status st = load(dir, &seq);
  ASSERT_TRUE(st.isOk()) << st.message();
  EXPECT_TRUE(seq.has_times);
  EXPECT_EQ(seq.t_ns, (std::vector<int64_t>{0, 103'735'900, 207'388'000}));

  writeFile(fs::path(dir) / "times.txt", "0.0\n0.2\n0.1\n");
  expectError(load(dir, &seq), "times.txt:3: time 0.1 s does not increase");
  writeFile(fs::path(dir) / "times.txt", "0.0\n0.1\n");
  expectError(load(dir, &seq), "times.txt has 2 lines but 3 are needed");
}

// A camera moving 1 m along its optical axis is the body moving 1 m along x; frame 0 is the
// identity whatever the camera's first pose in KITTI's world.
TEST(Kitti, ForwardCameraMotionIsBodyPlusX) {
  Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
  T0.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).matrix();
  T0.translation() = Eigen::Vector3d(5.0, -1.0, 2.0);
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  const std::vector<Eigen::Isometry3d> T_w_cam0 = {T0, T0 * step};
  const std::string dir = makeSequence("kitti_forward", T_w_cam0);
  KittiSequence seq;
  ASSERT_TRUE(load(dir, &seq).isOk());
  ASSERT_EQ(seq.T_w_b.size(), 2u);
  EXPECT_TRUE(seq.T_w_b[0].isApprox(Eigen::Isometry3d::Identity(), kParseTol))
      << seq.T_w_b[0].matrix();
  EXPECT_TRUE(seq.T_w_b[1].translation().isApprox(Eigen::Vector3d(1.0, 0.0, 0.0), kParseTol))
      << seq.T_w_b[1].translation().transpose();
  EXPECT_TRUE(seq.T_w_b[1].linear().isApprox(Eigen::Matrix3d::Identity(), kParseTol));

  // Moving down in the image (camera +y) is body -z; to the right (camera +x) is body -y.
  Eigen::Isometry3d down_right = Eigen::Isometry3d::Identity();
  down_right.translation() = Eigen::Vector3d(0.5, 0.25, 0.0);
  const auto body = kittiBodyPoses({T0, T0 * down_right}, kittiBodyFromLeftCamera());
  EXPECT_TRUE(body[1].translation().isApprox(Eigen::Vector3d(0.0, -0.5, -0.25), kParseTol))
      << body[1].translation().transpose();
}

// A left turn (counter-clockwise seen from above, positive yaw about body z = camera -y) keeps
// its sign: the camera's rotation about its y axis (pointing down) by -theta is body yaw +theta.
TEST(Kitti, LeftTurnIsPositiveYaw) {
  constexpr double kTurnRad = 0.2;
  Eigen::Isometry3d turned = Eigen::Isometry3d::Identity();
  turned.linear() = Eigen::AngleAxisd(-kTurnRad, Eigen::Vector3d::UnitY()).matrix();
  // After turning left the car drives 2 m along its new heading: forward-left in the world.
  turned.translation() = turned.linear() * Eigen::Vector3d(0.0, 0.0, 2.0);
  const auto body =
      kittiBodyPoses({Eigen::Isometry3d::Identity(), turned}, kittiBodyFromLeftCamera());
  const Eigen::Matrix3d R = body[1].linear();
  EXPECT_NEAR(std::atan2(R(1, 0), R(0, 0)), kTurnRad, kParseTol);
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d::UnitZ(), kParseTol)) << "z stays up";
  EXPECT_GT(body[1].translation().y(), 0.0) << "left of the start";
  EXPECT_NEAR(body[1].translation().x(), 2.0 * std::cos(kTurnRad), kParseTol);
  EXPECT_NEAR(body[1].translation().y(), 2.0 * std::sin(kTurnRad), kParseTol);
}

TEST(Kitti, MaxFramesNeedsAtLeastThatManyPoses) {
  const std::string dir = makeSequence("kitti_max", forward(5));
  KittiSequence seq;
  ASSERT_TRUE(load(dir, &seq, 2).isOk());
  EXPECT_EQ(seq.pairs_available, 5);
  EXPECT_EQ(seq.left_paths.size(), 2u);
  EXPECT_EQ(seq.T_w_b.size(), 2u);
  EXPECT_EQ(seq.t_ns.size(), 2u);
  // Three pose lines: enough for two frames, not for all five.
  std::string three;
  for (const auto& T : forward(3)) three += poseLine(T) + "\n";
  writeFile(fs::path(dir) / "poses.txt", three);
  EXPECT_TRUE(load(dir, &seq, 2).isOk());
  expectError(load(dir, &seq, 4), "poses.txt has 3 lines but at least 4 are needed");
  expectError(load(dir, &seq), "poses.txt has 3 lines but 5 are needed");
  expectError(load(dir, &seq, 0), "max_frames = 0");
}

TEST(Kitti, MissingFolderOrImagesAreErrorsNamingThePath) {
  KittiSequence seq;
  const std::string root = test::makeTempDir("kitti_missing");
  expectError(load(root + "/nope", &seq), "'" + root + "/nope' does not exist");
  expectError(load(root, &seq), "no left image folder (image_0/ or image_l/)");

  {
    const std::string dir = makeSequence("kitti_missing_right", forward(3));
    fs::remove(fs::path(dir) / "image_1" / "000001.png");
    expectError(load(dir, &seq), "image " + dir + "/image_1/000001.png is missing");
  }
  {
    const std::string dir = makeSequence("kitti_missing_last", forward(3));
    fs::remove(fs::path(dir) / "image_0" / "000002.png");
    expectError(load(dir, &seq), dir + "/image_0/000002.png is missing");
  }
  {
    const std::string dir = makeSequence("kitti_both_spellings", forward(2));
    fs::create_directories(fs::path(dir) / "image_l");
    expectError(load(dir, &seq), "has both image_0/ and image_l/");
  }
  {
    const std::string dir = makeSequence("kitti_no_calib", forward(2));
    fs::remove(fs::path(dir) / "calib.txt");
    expectError(load(dir, &seq), dir + "/calib.txt: no such file");
  }
}

TEST(Kitti, WrongPoseCountOrBadPoseLineNamesTheFileAndNumbers) {
  const std::string dir = makeSequence("kitti_poses", forward(3));
  const fs::path poses = fs::path(dir) / "poses.txt";
  KittiSequence seq;
  std::string text;
  for (const auto& T : forward(4)) text += poseLine(T) + "\n";
  writeFile(poses, text + "\n");  // a trailing blank line is fine, four poses are not
  expectError(load(dir, &seq), poses.string() + " has 4 lines but 3 are needed");

  text.clear();
  for (const auto& T : forward(2)) text += poseLine(T) + "\n";
  writeFile(poses, text + "1 0 0 0 0 1 0 0 0 0 1\n");
  expectError(load(dir, &seq), poses.string() + ":3: expected 12 numbers, got 11");
  writeFile(poses, text + "1 0 0 0 0 1 0 0 0 0 x 0\n");
  expectError(load(dir, &seq), ":3: 'x' is not a finite number");
  writeFile(poses, text + "2 0 0 0 0 1 0 0 0 0 1 0\n");
  expectError(load(dir, &seq), ":3: not a rigid transform");
}

TEST(Kitti, BadCalibrationLinesNameTheFileAndLine) {
  const std::string dir = makeSequence("kitti_calib", forward(2));
  const fs::path calib = fs::path(dir) / "calib.txt";
  const std::string p0 = row(projection(0.0));
  const std::string p1 = row(projection(-kFx * kBaselineM));
  KittiSequence seq;
  const auto expect_calib_error = [&](const std::string& text, const std::string& what) {
    writeFile(calib, text);
    expectError(load(dir, &seq), what);
  };
  expect_calib_error("P0: " + p0 + "\nP1: 1 2 3\n", calib.string() + ":2: P1: expected 12 numbers");
  expect_calib_error(p0 + "\n" + p1 + " 7\n",
                     calib.string() + ":2: P1: expected 12 numbers, got 13");
  expect_calib_error("P0: " + p0 + "\n" + p1 + "\n", ":2: mixes named lines");
  expect_calib_error("P0: " + p0 + "\nP2: " + p1 + "\n", "no P1");
  expect_calib_error("P0: " + p0 + "\nP1: " + row(projection(kFx * kBaselineM)) + "\n",
                     ":2: baseline -P1[0][3] / P1[0][0] = -0.54 m; must be > 0");
  expect_calib_error("P0: " + row(projection(3.0)) + "\nP1: " + p1 + "\n",
                     ":1: P0's last column must be zero");
  Eigen::Matrix<double, 3, 4> other = projection(-kFx * kBaselineM);
  other(0, 2) += 4.0;
  expect_calib_error("P0: " + p0 + "\nP1: " + row(other) + "\n", ":2: P1[0][2] = 23.5 differs");
  expect_calib_error("P0: " + p0 + "\nP1: " + p1 + "\nP0: " + p0 + "\n",
                     ":3: P0 is given twice (first on line 1)");
}

// The shared excerpt (skipped when ../shared/data is absent): 51 pairs, KITTI's sequence
// calibration, a 5 s drive of about 60 m straight ahead.
TEST(Kitti, ReadsTheSharedSequence) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  KittiSequence seq;
  const Status st = load(data + "/kitti_seq_a", &seq);
  ASSERT_TRUE(st.isOk()) << st.message();
  EXPECT_EQ(seq.pairs_available, 51);
  EXPECT_EQ(seq.rig.width_px, 1226);
  EXPECT_EQ(seq.rig.height_px, 370);
  EXPECT_NEAR(seq.rig.baseline_m, kSeqABaselineM, kSeqABaselineTolM);
  ASSERT_EQ(seq.T_w_b.size(), 51u);
  EXPECT_EQ(seq.t_ns.back(), 5'000'000'000);
  double path_m = 0.0;
  for (size_t k = 1; k < seq.T_w_b.size(); ++k)
    path_m += (seq.T_w_b[k].translation() - seq.T_w_b[k - 1].translation()).norm();
  EXPECT_NEAR(path_m, kSeqAPathM, kSeqAPathTolM);
  // Driving ahead: the end lies ~60 m along body x, within a few metres of the axis.
  const Eigen::Vector3d end = seq.T_w_b.back().translation();
  EXPECT_GT(end.x(), 55.0);
  EXPECT_LT(std::abs(end.y()), 5.0);
  EXPECT_LT(std::abs(end.z()), 5.0);
}

}  // namespace
}  // namespace twocam::io
