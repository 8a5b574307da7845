#include "io/euroc.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "support/test_paths.h"

namespace twocam::io {
namespace {

namespace fs = std::filesystem;

// Values are parsed from decimal text into doubles: exact up to rounding.
constexpr double kParseTol = 1e-12;
// T_BS is re-orthonormalised on load; EuRoC prints ~12 digits, so entries move by ~1e-11.
constexpr double kPoseEntryTol = 1e-9;

// A sensor.yaml in EuRoC's layout (the values of V1_01_easy's cam0).
std::string sensorYaml(const std::string& header = "%YAML:1.0\n") {
  return header +
         "# General sensor definitions.\n"
         "sensor_type: camera\n"
         "comment: VI-Sensor cam0 (MT9M034)\n"
         "\n"
         "# Sensor extrinsics wrt. the body-frame.\n"
         "T_BS:\n"
         "  cols: 4\n"
         "  rows: 4\n"
         "  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,\n"
         "         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,\n"
         "        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,\n"
         "         0.0, 0.0, 0.0, 1.0]\n"
         "\n"
         "# Camera specific definitions.\n"
         "rate_hz: 20\n"
         "resolution: [752, 480]\n"
         "camera_model: pinhole\n"
         "intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv\n"
         "distortion_model: radial-tangential\n"
         "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n";
}

void writeFile(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

std::string replaceLine(std::string text, const std::string& prefix, const std::string& line) {
  const size_t at = text.find(prefix);
  EXPECT_NE(at, std::string::npos) << prefix;
  if (at == std::string::npos) return text;
  const size_t end = text.find('\n', at);
  return text.replace(at, end - at, line);
}

void expectCam0Values(const CameraCalibration& c) {
  EXPECT_EQ(c.width, 752);
  EXPECT_EQ(c.height, 480);
  EXPECT_NEAR(c.fx, 458.654, kParseTol);
  EXPECT_NEAR(c.fy, 457.296, kParseTol);
  EXPECT_NEAR(c.cx, 367.215, kParseTol);
  EXPECT_NEAR(c.cy, 248.375, kParseTol);
  EXPECT_NEAR(c.radtan[0], -0.28340811, kParseTol);
  EXPECT_NEAR(c.radtan[1], 0.07395907, kParseTol);
  EXPECT_NEAR(c.radtan[2], 0.00019359, kParseTol);
  EXPECT_NEAR(c.radtan[3], 1.76187114e-05, kParseTol);
  EXPECT_NEAR(c.rate_hz, 20.0, kParseTol);
  const Eigen::Matrix4d M = c.T_b_c.matrix();
  EXPECT_NEAR(M(0, 0), 0.0148655429818, kPoseEntryTol);
  EXPECT_NEAR(M(0, 1), -0.999880929698, kPoseEntryTol);
  EXPECT_NEAR(M(1, 0), 0.999557249008, kPoseEntryTol);
  EXPECT_NEAR(M(2, 2), 0.999660727178, kPoseEntryTol);
  EXPECT_NEAR(M(0, 3), -0.0216401454975, kParseTol);
  EXPECT_NEAR(M(1, 3), -0.064676986768, kParseTol);
  EXPECT_NEAR(M(2, 3), 0.00981073058949, kParseTol);
  EXPECT_TRUE(c.validate().isOk());
}

TEST(EurocCamera, ReadsEurocStyleYaml) {
  const fs::path dir = test::makeTempDir("euroc_yaml");
  writeFile(dir / "sensor.yaml", sensorYaml());
  CameraCalibration c;
  const Status s = loadEurocCamera((dir / "sensor.yaml").string(), &c);
  ASSERT_TRUE(s.isOk()) << s.message();
  expectCam0Values(c);
}

TEST(EurocCamera, AcceptsStandardHeaderOrNone) {
  const fs::path dir = test::makeTempDir("euroc_headers");
  for (const std::string header : {"%YAML 1.2\n---\n", ""}) {
    writeFile(dir / "sensor.yaml", sensorYaml(header));
    CameraCalibration c;
    const Status s = loadEurocCamera((dir / "sensor.yaml").string(), &c);
    ASSERT_TRUE(s.isOk()) << "header '" << header << "': " << s.message();
    expectCam0Values(c);
  }
}

TEST(EurocCamera, RealEurocMicroCalibration) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  const std::string mav0 = data + "/euroc_micro/mav0";
  CameraCalibration left;
  CameraCalibration right;
  const Status s = loadEurocStereoCalibration(mav0, &left, &right);
  ASSERT_TRUE(s.isOk()) << s.message();
  expectCam0Values(left);
  // cam1 numbers from mav0/cam1/sensor.yaml.
  EXPECT_EQ(right.width, 752);
  EXPECT_EQ(right.height, 480);
  EXPECT_NEAR(right.fx, 457.587, kParseTol);
  EXPECT_NEAR(right.fy, 456.134, kParseTol);
  EXPECT_NEAR(right.cx, 379.999, kParseTol);
  EXPECT_NEAR(right.cy, 255.238, kParseTol);
  EXPECT_NEAR(right.radtan[0], -0.28368365, kParseTol);
  EXPECT_NEAR(right.radtan[1], 0.07451284, kParseTol);
  EXPECT_NEAR(right.radtan[2], -0.00010473, kParseTol);
  EXPECT_NEAR(right.radtan[3], -3.55590700e-05, kParseTol);
  EXPECT_NEAR(right.T_b_c(1, 3), 0.0453689425024, kParseTol);
  // The README's 0.110 m baseline, from the two T_BS.
  constexpr double kBaselineTolM = 0.002;
  const Eigen::Isometry3d T_cl_cr = left.T_b_c.inverse() * right.T_b_c;
  EXPECT_NEAR(T_cl_cr.translation().norm(), 0.110, kBaselineTolM);
  // cam1 is to the right of cam0 (+x of the left optical frame).
  EXPECT_GT(T_cl_cr.translation().x(), 0.1);
}

TEST(EurocStereoIndex, RealEurocMicroPairsAllFrames) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  EurocStereoIndex index;
  const Status s = loadEurocStereoIndex(data + "/euroc_micro/mav0", &index);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_EQ(index.t_ns.size(), 19u);
  ASSERT_EQ(index.left_paths.size(), 19u);
  ASSERT_EQ(index.right_paths.size(), 19u);
  EXPECT_TRUE(index.unmatched_left_t_ns.empty());
  EXPECT_TRUE(index.unmatched_right_t_ns.empty());
  EXPECT_EQ(index.t_ns.front(), 1403715274312143104LL);
  EXPECT_EQ(index.t_ns.back(), 1403715275212143104LL);
  for (size_t i = 0; i < index.t_ns.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(index.t_ns[i], index.t_ns[i - 1]);
    }
    EXPECT_TRUE(fs::is_regular_file(index.left_paths[i])) << index.left_paths[i];
    EXPECT_NE(index.left_paths[i].find("cam0"), std::string::npos);
    EXPECT_NE(index.right_paths[i].find("cam1"), std::string::npos);
    EXPECT_EQ(fs::path(index.left_paths[i]).stem().string(), std::to_string(index.t_ns[i]));
  }
}

// A small mav0 folder: cam0 and cam1 list the given stamps and hold empty image files.
fs::path makeMav0(const std::string& name,
                  const std::vector<int64_t>& left,
                  const std::vector<int64_t>& right,
                  const std::string& line_end = "\n") {
  const fs::path mav0 = fs::path(test::makeTempDir(name)) / "mav0";
  for (const auto& [cam, stamps] : {std::pair{"cam0", left}, std::pair{"cam1", right}}) {
    std::string csv = "#timestamp [ns],filename" + line_end;
    for (int64_t t : stamps) {
      csv += std::to_string(t) + "," + std::to_string(t) + ".png" + line_end;
      writeFile(mav0 / cam / "data" / (std::to_string(t) + ".png"), "");
    }
    writeFile(mav0 / cam / "data.csv", csv);
    writeFile(mav0 / cam / "sensor.yaml", sensorYaml());
  }
  return mav0;
}

TEST(EurocStereoIndex, DropsAndReportsUnmatchedStamps) {
  const fs::path mav0 =
      makeMav0("euroc_unmatched", {100, 200, 300, 400, 500}, {50, 200, 300, 450, 500, 600});
  EurocStereoIndex index;
  const Status s = loadEurocStereoIndex(mav0.string(), &index);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(index.t_ns, (std::vector<int64_t>{200, 300, 500}));
  EXPECT_EQ(index.unmatched_left_t_ns, (std::vector<int64_t>{100, 400}));
  EXPECT_EQ(index.unmatched_right_t_ns, (std::vector<int64_t>{50, 450, 600}));
  EXPECT_EQ(fs::path(index.right_paths[1]).filename().string(), "300.png");
}

TEST(EurocStereoIndex, PairsWithinToleranceAndAcceptsCrLf) {
  const fs::path mav0 = makeMav0("euroc_tolerance", {1000, 2000, 3000}, {1003, 1998, 3500}, "\r\n");
  EurocIndexOptions options;
  options.max_pair_offset_ns = 5;
  EurocStereoIndex index;
  const Status s = loadEurocStereoIndex(mav0.string(), &index, options);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(index.t_ns, (std::vector<int64_t>{1000, 2000}));
  EXPECT_EQ(fs::path(index.right_paths[0]).filename().string(), "1003.png");
  EXPECT_EQ(index.unmatched_left_t_ns, (std::vector<int64_t>{3000}));
  EXPECT_EQ(index.unmatched_right_t_ns, (std::vector<int64_t>{3500}));
  options.max_pair_offset_ns = -1;
  EXPECT_FALSE(loadEurocStereoIndex(mav0.string(), &index, options).isOk());
}

// --- Bad input -------------------------------------------------------------------------------

void expectErrorMentions(const Status& s, const std::vector<std::string>& words) {
  ASSERT_FALSE(s.isOk());
  for (const auto& w : words) EXPECT_NE(s.message().find(w), std::string::npos) << s.message();
}

// Writes `text` as a sensor.yaml, loads it and expects an error naming the file and `words`.
void expectYamlRejected(const std::string& name,
                        const std::string& text,
                        const std::vector<std::string>& words) {
  const fs::path dir = test::makeTempDir(name);
  const std::string path = (dir / "sensor.yaml").string();
  writeFile(path, text);
  CameraCalibration c;
  std::vector<std::string> all = words;
  all.push_back(path);
  expectErrorMentions(loadEurocCamera(path, &c), all);
}

TEST(EurocCamera, MissingFileNamesIt) {
  CameraCalibration c;
  expectErrorMentions(loadEurocCamera("/nonexistent/cam0/sensor.yaml", &c),
                      {"/nonexistent/cam0/sensor.yaml"});
}

TEST(EurocCamera, MissingKeyNamesFileAndKey) {
  for (const std::string key :
       {"intrinsics", "resolution", "distortion_model", "distortion_coefficients"}) {
    expectYamlRejected("euroc_missing_key",
                       replaceLine(sensorYaml(), key + ":", ""),
                       {"'" + key + "'", "missing"});
  }
  std::string text = sensorYaml();
  const size_t at = text.find("T_BS:");
  text.replace(at, text.find("# Camera") - at, "");
  expectYamlRejected("euroc_missing_tbs", text, {"'T_BS'", "missing"});
  expectYamlRejected(
      "euroc_missing_rows", replaceLine(sensorYaml(), "  rows:", ""), {"'T_BS.rows'", "missing"});
}

TEST(EurocCamera, RejectsUnsupportedOrMalformedValues) {
  expectYamlRejected(
      "euroc_equidistant",
      replaceLine(sensorYaml(), "distortion_model:", "distortion_model: equidistant"),
      {"'distortion_model'", "equidistant"});
  expectYamlRejected("euroc_five_coeffs",
                     replaceLine(sensorYaml(),
                                 "distortion_coefficients:",
                                 "distortion_coefficients: [0.1, 0.2, 0.0, 0.0, 0.3]"),
                     {"'distortion_coefficients'", "5 values"});
  expectYamlRejected("euroc_omni",
                     replaceLine(sensorYaml(), "camera_model:", "camera_model: omni"),
                     {"'camera_model'", "omni"});
  expectYamlRejected("euroc_text_intrinsics",
                     replaceLine(sensorYaml(), "intrinsics:", "intrinsics: [a, b, c, d]"),
                     {"'intrinsics'", "not a number"});
  expectYamlRejected(
      "euroc_negative_focal",
      replaceLine(sensorYaml(), "intrinsics:", "intrinsics: [-458.6, 457.3, 367.2, 248.4]"),
      {"focal"});
  expectYamlRejected(
      "euroc_not_rigid",
      replaceLine(sensorYaml(),
                  "  data: [0.0148655429818",
                  "  data: [0.5, -0.999880929698, 0.00414029679422, -0.0216401454975,"),
      {"'T_BS'", "rigid"});
  // Syntax errors name the line of the file as written (no directive: OpenCV's is prepended).
  expectYamlRejected("euroc_syntax", "%YAML:1.0\nintrinsics: [1, 2\nfoo: : :\n", {":3:", "YAML"});
  expectYamlRejected("euroc_syntax_no_directive", "intrinsics: [1, 2\nfoo: : :\n", {":2:", "YAML"});
  expectYamlRejected("euroc_empty", "", {"empty"});
}

TEST(EurocStereoIndex, MissingImageListedInCsvNamesIt) {
  const fs::path mav0 = makeMav0("euroc_missing_image", {100, 200, 300}, {100, 200, 300});
  fs::remove(mav0 / "cam1" / "data" / "200.png");
  EurocStereoIndex index;
  expectErrorMentions(loadEurocStereoIndex(mav0.string(), &index),
                      {(mav0 / "cam1" / "data.csv").string() + ":3", "200.png", "does not exist"});
}

TEST(EurocStereoIndex, RejectsMalformedCsv) {
  EurocStereoIndex index;
  {
    const fs::path mav0 = makeMav0("euroc_bad_line", {100, 200}, {100, 200});
    writeFile(mav0 / "cam0" / "data.csv", "#timestamp [ns],filename\n100,100.png\nabc,200.png\n");
    expectErrorMentions(loadEurocStereoIndex(mav0.string(), &index), {"cam0/data.csv:3", "abc"});
  }
  {
    const fs::path mav0 = makeMav0("euroc_no_comma", {100, 200}, {100, 200});
    writeFile(mav0 / "cam1" / "data.csv", "100 100.png\n");
    expectErrorMentions(loadEurocStereoIndex(mav0.string(), &index), {"cam1/data.csv:1"});
  }
  {
    const fs::path mav0 = makeMav0("euroc_decreasing", {100, 200}, {100, 200});
    writeFile(mav0 / "cam0" / "data.csv", "200,200.png\n100,100.png\n");
    expectErrorMentions(loadEurocStereoIndex(mav0.string(), &index),
                        {"cam0/data.csv:2", "increase"});
  }
  {
    const fs::path mav0 = makeMav0("euroc_disjoint", {100, 200}, {150, 250});
    expectErrorMentions(loadEurocStereoIndex(mav0.string(), &index), {"no cam0 and cam1"});
  }
  expectErrorMentions(loadEurocStereoIndex("/nonexistent/mav0", &index), {"/nonexistent/mav0"});
}

TEST(EurocStereoCalibration, RejectsDifferentImageSizes) {
  const fs::path mav0 = makeMav0("euroc_sizes", {100}, {100});
  writeFile(mav0 / "cam1" / "sensor.yaml",
            replaceLine(sensorYaml(), "resolution:", "resolution: [640, 480]"));
  CameraCalibration left;
  CameraCalibration right;
  expectErrorMentions(loadEurocStereoCalibration(mav0.string(), &left, &right),
                      {"752x480", "640x480"});
}

}  // namespace
}  // namespace twocam::io
