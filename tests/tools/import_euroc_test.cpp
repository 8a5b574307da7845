// `twocam import-euroc`: runs the built binary on the shared EuRoC excerpt (skipped when
// ../shared/data is absent) and on broken copies of it, and reads the imported log back.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "frontend/cv_interop.h"
#include "frontend/rectify.h"
#include "io/euroc.h"
#include "io/rawlog.h"
#include "support/command.h"
#include "support/test_paths.h"

namespace twocam {
namespace {

namespace fs = std::filesystem;

// Rig values go through the log as doubles (CPose3DQuat for T_b_cl): rounding only.
constexpr double kRigTol = 1e-9;
// MRPT stores time in 100 ns ticks; TwoCam keeps t_ns as ticks, truncated.
constexpr int64_t kTickNs = 100;

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

/// A writable copy of the excerpt's mav0 with its first n stereo pairs: DIR/seq/mav0.
std::string copyMicro(const std::string& micro_mav0, const std::string& dir, int n) {
  const fs::path mav0 = fs::path(dir) / "seq" / "mav0";
  for (const char* cam : {"cam0", "cam1"}) {
    fs::create_directories(mav0 / cam / "data");
    fs::copy_file(fs::path(micro_mav0) / cam / "sensor.yaml", mav0 / cam / "sensor.yaml");
    std::ifstream in(fs::path(micro_mav0) / cam / "data.csv");
    std::ofstream out(mav0 / cam / "data.csv");
    std::string line;
    int copied = 0;
    while (std::getline(in, line) && copied < n) {
      out << line << "\n";
      if (line.empty() || line[0] == '#') continue;
      const std::string name = line.substr(line.find(',') + 1);
      fs::copy_file(fs::path(micro_mav0) / cam / "data" / name, mav0 / cam / "data" / name);
      ++copied;
    }
  }
  fs::permissions(mav0, fs::perms::owner_all, fs::perm_options::add);
  for (const auto& e : fs::recursive_directory_iterator(mav0))
    fs::permissions(e.path(), fs::perms::owner_all, fs::perm_options::add);
  return mav0.string();
}

/// Expects a one-line "twocam import-euroc: error: ..." containing `text`, exit code 1.
void expectError(const RunResult& r, const std::string& text) {
  EXPECT_EQ(r.exit_code, 1) << r.output << r.error;
  EXPECT_EQ(r.error.rfind("twocam import-euroc: error: ", 0), 0u) << r.error;
  EXPECT_EQ(std::count(r.error.begin(), r.error.end(), '\n'), 1) << r.error;
  EXPECT_NE(r.error.find(text), std::string::npos) << "expected '" << text << "' in: " << r.error;
}

struct RowStats {
  double median_abs_dv_px = 0.0;
  size_t matches = 0;
};

// Shi-Tomasi corners tracked left -> right with pyramidal Lucas-Kanade and a 0.3 px
// forward-backward check (as tests/frontend/rectify_test.cpp); median |v_left - v_right|.
RowStats rowOffsets(const std::vector<std::pair<ImageU8, ImageU8>>& pairs) {
  std::vector<double> abs_dv;
  for (const auto& [l, r] : pairs) {
    const cv::Mat left = frontend::asMat(l);
    const cv::Mat right = frontend::asMat(r);
    std::vector<cv::Point2f> corners, tracked, back;
    std::vector<uint8_t> ok_fwd, ok_bwd;
    std::vector<float> err;
    cv::goodFeaturesToTrack(left, corners, 400, 0.01, 10);
    cv::calcOpticalFlowPyrLK(left, right, corners, tracked, ok_fwd, err, cv::Size(21, 21), 3);
    cv::calcOpticalFlowPyrLK(right, left, tracked, back, ok_bwd, err, cv::Size(21, 21), 3);
    constexpr double kForwardBackwardPx = 0.3;
    for (size_t i = 0; i < corners.size(); ++i) {
      if (!ok_fwd[i] || !ok_bwd[i] || cv::norm(back[i] - corners[i]) > kForwardBackwardPx) continue;
      abs_dv.push_back(std::abs(corners[i].y - tracked[i].y));
    }
  }
  RowStats s;
  s.matches = abs_dv.size();
  if (abs_dv.empty()) return s;
  std::nth_element(
      abs_dv.begin(), abs_dv.begin() + static_cast<long>(abs_dv.size() / 2), abs_dv.end());
  s.median_abs_dv_px = abs_dv[abs_dv.size() / 2];
  return s;
}

TEST(ImportEuroc, HelpListsTheCommand) {
  const RunResult r = run("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("import-euroc"), std::string::npos);
  const RunResult h = run("import-euroc --help");
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.output.find("--max-frames"), std::string::npos);
}

// The whole excerpt: every pair rectified into the log, read back without odometry, rig and
// images exactly as the rectifier makes them; rows align after import and did not before.
TEST(ImportEuroc, ImportsTheMicroSequenceRectifiedWithoutOdometry) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string seq = data + "/euroc_micro";
  const std::string mav0 = seq + "/mav0";
  const std::string dir = test::makeTempDir("import_euroc_micro");
  const std::string log = dir + "/v101.rawlog";
  const RunResult r = run("import-euroc " + seq + " -o " + log);
  ASSERT_EQ(r.exit_code, 0) << r.output << r.error;
  std::cout << r.output;
  EXPECT_NE(r.error.find("import-euroc"), std::string::npos) << "progress bar expected on stderr";
  EXPECT_FALSE(fs::exists(log + ".partial"));
  EXPECT_TRUE(fs::is_directory(dir + "/v101_Images"));

  CameraCalibration cam0, cam1;
  ASSERT_TRUE(io::loadEurocStereoCalibration(mav0, &cam0, &cam1).isOk());
  io::EurocStereoIndex index;
  ASSERT_TRUE(io::loadEurocStereoIndex(mav0, &index).isOk());
  frontend::StereoRectifier rectifier;
  ASSERT_TRUE(
      frontend::StereoRectifier::create(cam0, cam1, frontend::RectifyOptions(), &rectifier).isOk());
  EXPECT_NE(r.output.find("imported " + std::to_string(index.t_ns.size()) + " of " +
                          std::to_string(index.t_ns.size())),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("dropped 0 cam0 and 0 cam1"), std::string::npos) << r.output;

  std::unique_ptr<io::RawlogReader> reader;
  const Status st = io::RawlogReader::open(log, &reader);
  ASSERT_TRUE(st.isOk()) << st.message();
  const StereoRig& want = rectifier.rig();
  const StereoRig& got = reader->rig();
  EXPECT_EQ(got.width_px, cam0.width);
  EXPECT_EQ(got.height_px, cam0.height);
  EXPECT_NEAR(got.fx_px, want.fx_px, kRigTol);
  EXPECT_NEAR(got.cx_px, want.cx_px, kRigTol);
  EXPECT_NEAR(got.cy_px, want.cy_px, kRigTol);
  EXPECT_NEAR(got.baseline_m, want.baseline_m, kRigTol);
  EXPECT_TRUE(got.T_b_cl.isApprox(want.T_b_cl, kRigTol)) << got.T_b_cl.matrix() << "\n vs \n"
                                                         << want.T_b_cl.matrix();
  // The rectified left camera's optical axis stays close to the raw cam0's (Bouguet splits the
  // rotation between both cameras; EuRoC's cameras are nearly parallel).
  constexpr double kMaxRectifyingRotationRad = 0.05;
  const Eigen::AngleAxisd rect_rotation(cam0.T_b_c.linear().transpose() * got.T_b_cl.linear());
  EXPECT_LT(std::abs(rect_rotation.angle()), kMaxRectifyingRotationRad);
  EXPECT_TRUE(got.T_b_cl.translation().isApprox(cam0.T_b_c.translation(), kRigTol));

  std::vector<std::pair<ImageU8, ImageU8>> raw_pairs, imported_pairs;
  io::LogFrame f;
  Status rs;
  size_t k = 0;
  while (reader->next(&f, &rs)) {
    ASSERT_LT(k, index.t_ns.size());
    EXPECT_EQ(f.index, static_cast<int>(k));
    EXPECT_EQ(f.stereo.t_ns, index.t_ns[k] / kTickNs * kTickNs) << k;
    EXPECT_FALSE(f.odometry.has_value()) << "EuRoC has no wheel odometry; frame " << k;
    EXPECT_FALSE(f.ground_truth.has_value()) << k;
    ImageU8 raw_left, raw_right, left, right;
    ASSERT_TRUE(frontend::loadGrey(index.left_paths[k], &raw_left).isOk());
    ASSERT_TRUE(frontend::loadGrey(index.right_paths[k], &raw_right).isOk());
    if (k == 0) {
      ASSERT_TRUE(rectifier.rectify(raw_left, raw_right, &left, &right).isOk());
      EXPECT_EQ(f.stereo.left.data, left.data)
          << "imported images are the rectifier's output, losslessly";
      EXPECT_EQ(f.stereo.right.data, right.data);
    }
    if (k % 6 == 0) {
      raw_pairs.emplace_back(std::move(raw_left), std::move(raw_right));
      imported_pairs.emplace_back(f.stereo.left, f.stereo.right);
    }
    ++k;
  }
  EXPECT_TRUE(rs.isOk()) << rs.message();
  EXPECT_EQ(k, index.t_ns.size());

  const RowStats raw = rowOffsets(raw_pairs);
  const RowStats imported = rowOffsets(imported_pairs);
  std::cout << "[ import  ] " << raw_pairs.size() << " pairs; raw: " << raw.matches
            << " matches, median |dv| = " << raw.median_abs_dv_px
            << " px; imported log: " << imported.matches
            << " matches, median |dv| = " << imported.median_abs_dv_px << " px\n";
  ASSERT_GT(imported.matches, 200u);
  constexpr double kMaxMedianRowOffsetPx = 0.3;  // as in rectify_test's acceptance threshold
  EXPECT_LT(imported.median_abs_dv_px, kMaxMedianRowOffsetPx);
  EXPECT_GT(raw.median_abs_dv_px, imported.median_abs_dv_px);
}

TEST(ImportEuroc, AcceptsMav0ItselfAndMaxFrames) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string dir = test::makeTempDir("import_euroc_mav0");
  const std::string log = dir + "/three.rawlog";
  const RunResult r =
      run("import-euroc " + data + "/euroc_micro/mav0 -o " + log + " --max-frames 3 --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output << r.error;
  EXPECT_TRUE(r.error.empty()) << "--quiet: no progress bar, got: " << r.error;
  EXPECT_NE(r.output.find("imported 3 of"), std::string::npos) << r.output;
  std::unique_ptr<io::RawlogReader> reader;
  ASSERT_TRUE(io::RawlogReader::open(log, &reader).isOk());
  io::LogFrame f;
  Status rs;
  int n = 0;
  while (reader->next(&f, &rs)) {
    EXPECT_FALSE(f.odometry.has_value());
    ++n;
  }
  EXPECT_TRUE(rs.isOk()) << rs.message();
  EXPECT_EQ(n, 3);

  expectError(
      run("import-euroc " + data + "/euroc_micro -o " + dir + "/zero.rawlog --max-frames 0 -q"),
      "--max-frames 0");
  EXPECT_FALSE(fs::exists(dir + "/zero.rawlog"));
}

// Every error: one line, exit 1, no log and no partial files; an earlier log at the output path
// and its images survive untouched.
TEST(ImportEuroc, ErrorsLeaveNoLogAndKeepAnEarlierOne) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string micro = data + "/euroc_micro/mav0";
  const std::string dir = test::makeTempDir("import_euroc_errors");
  const std::string log = dir + "/out.rawlog";
  const std::string images = dir + "/out_Images";
  {
    const std::string good = copyMicro(micro, dir + "/good", 2);
    const RunResult r = run("import-euroc " + good + " -o " + log + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.output << r.error;
  }
  const std::string log_bytes = readFile(log);
  const std::string image_bytes = readFile(images + "/left_000001.png");
  ASSERT_FALSE(log_bytes.empty());
  auto expect_untouched = [&](const std::string& what) {
    EXPECT_EQ(readFile(log), log_bytes) << what << ": the earlier log changed";
    EXPECT_EQ(readFile(images + "/left_000001.png"), image_bytes)
        << what << ": the earlier images changed";
    EXPECT_FALSE(fs::exists(log + ".partial")) << what;
    EXPECT_FALSE(fs::exists(images + ".partial")) << what;
  };

  expectError(run("import-euroc " + dir + "/no_such_folder -o " + log + " -q"), "does not exist");
  expect_untouched("missing folder");

  fs::create_directories(dir + "/empty");
  expectError(run("import-euroc " + dir + "/empty -o " + log + " -q"), "is not a EuRoC sequence");
  expect_untouched("not a sequence");

  {
    const std::string mav0 = copyMicro(micro, dir + "/no_yaml", 3);
    fs::remove(mav0 + "/cam1/sensor.yaml");
    expectError(run("import-euroc " + dir + "/no_yaml/seq -o " + log + " -q"), "cam1/sensor.yaml");
    expect_untouched("missing sensor.yaml");
  }
  {
    const std::string mav0 = copyMicro(micro, dir + "/bad_yaml", 3);
    std::ofstream(mav0 + "/cam0/sensor.yaml")
        << "%YAML:1.0\nresolution: [752, 480\nintrinsics: {{{\n\x01\x02garbage";
    expectError(run("import-euroc " + dir + "/bad_yaml/seq -o " + log + " -q"), "cam0/sensor.yaml");
    expect_untouched("corrupt sensor.yaml");
  }
  {
    const std::string mav0 = copyMicro(micro, dir + "/no_image", 3);
    std::string name;
    for (const auto& e : fs::directory_iterator(mav0 + "/cam1/data")) name = e.path().string();
    fs::remove(name);
    expectError(run("import-euroc " + dir + "/no_image/seq -o " + log + " -q"),
                fs::path(name).filename().string());
    expect_untouched("missing image");
  }
  {
    // The third pair's right image has the wrong size: two frames are written before the error.
    const std::string mav0 = copyMicro(micro, dir + "/small_image", 3);
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(mav0 + "/cam1/data"))
      names.push_back(e.path().string());
    std::sort(names.begin(), names.end());
    ASSERT_EQ(names.size(), 3u);
    ASSERT_TRUE(cv::imwrite(names[2], cv::Mat(240, 376, CV_8UC1, cv::Scalar(128))));
    const RunResult r = run("import-euroc " + dir + "/small_image/seq -o " + log + " -q");
    expectError(r, "376x240");
    EXPECT_NE(r.error.find("752x480"), std::string::npos) << r.error;
    expect_untouched("image size");
  }
  {
    const std::string mav0 = copyMicro(micro, dir + "/corrupt_image", 2);
    std::string name;
    for (const auto& e : fs::directory_iterator(mav0 + "/cam0/data")) name = e.path().string();
    std::ofstream(name, std::ios::binary | std::ios::trunc) << "not a png";
    expectError(run("import-euroc " + dir + "/corrupt_image/seq -o " + log + " -q"),
                fs::path(name).filename().string());
    expect_untouched("corrupt image");
  }
  {
    const std::string good = dir + "/good/seq";
    expectError(run("import-euroc " + good + " -o " + dir + "/no_such_folder/out.rawlog -q"),
                "does not exist");
    std::ofstream(dir + "/a_file") << "x";
    expectError(run("import-euroc " + good + " -o " + dir + "/a_file/out.rawlog -q"), "a_file");
    expectError(run("import-euroc " + good + " -o " + dir + " -q"), "is a folder");
    expect_untouched("unwritable output");
  }
}

}  // namespace
}  // namespace twocam
