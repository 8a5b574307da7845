#include "eval/disparity_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "support/test_paths.h"

namespace twocam::eval {
namespace {

// Integer-coded ground truth divided by a power of two is exact in float.
constexpr float kExactF = 0.0f;
// fx * B / Z computed in double and stored as float: float's relative precision.
constexpr double kFloatRelTol = 1e-6;

std::string readBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Float bytes in the requested byte order.
std::string floatBytes(float value, bool little_endian) {
  uint32_t bits = 0;
  std::memcpy(&bits, &value, 4);
  std::string out(4, '\0');
  for (int i = 0; i < 4; ++i) {
    const int shift = little_endian ? 8 * i : 8 * (3 - i);
    out[static_cast<size_t>(i)] = static_cast<char>((bits >> shift) & 0xFFu);
  }
  return out;
}

/// A 2x2 PFM whose top row is (3, 4) and bottom row (1, 2), in the given byte order.
std::string handMadePfm(bool little_endian) {
  std::string s = little_endian ? "Pf\n2 2\n-1.0\n" : "Pf\n2 2\n1.0\n";
  for (float value : {1.0f, 2.0f, 3.0f, 4.0f}) s += floatBytes(value, little_endian);
  return s;
}

bool sameBits(float a, float b) { return std::memcmp(&a, &b, 4) == 0; }

// ---------------------------------------------------------------------------------------------
// PFM

TEST(DisparityIo, PfmRoundTripIsBitExact) {
  const std::string dir = test::makeTempDir("eval_pfm_roundtrip");
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<float> value(-5.0f, 80.0f);
  ImageF32 image(7, 5);
  for (float& x : image.data) x = value(rng);
  image(0, 0) = std::numeric_limits<float>::infinity();
  image(6, 4) = std::numeric_limits<float>::quiet_NaN();
  const std::string path = dir + "/map.pfm";
  ASSERT_TRUE(writePfm(path, image).isOk());
  ImageF32 back;
  const Status s = readPfm(path, &back);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_EQ(back.width, image.width);
  ASSERT_EQ(back.height, image.height);
  for (size_t i = 0; i < image.data.size(); ++i) {
    EXPECT_TRUE(sameBits(back.data[i], image.data[i])) << "pixel " << i;
  }
  // Header as Middlebury writes it, little-endian.
  EXPECT_EQ(readBytes(path).substr(0, 9), "Pf\n7 5\n-1");
}

TEST(DisparityIo, PfmRowsAreStoredBottomToTopInEitherByteOrder) {
  const std::string dir = test::makeTempDir("eval_pfm_order");
  for (bool little : {true, false}) {
    const std::string path = dir + (little ? "/le.pfm" : "/be.pfm");
    writeBytes(path, handMadePfm(little));
    ImageF32 image;
    const Status s = readPfm(path, &image);
    ASSERT_TRUE(s.isOk()) << s.message();
    EXPECT_EQ(image(0, 0), 3.0f) << (little ? "little" : "big");
    EXPECT_EQ(image(1, 0), 4.0f);
    EXPECT_EQ(image(0, 1), 1.0f);
    EXPECT_EQ(image(1, 1), 2.0f);
  }
}

TEST(DisparityIo, PfmGroundTruthMarksInfiniteAndNegativeInvalid) {
  const std::string dir = test::makeTempDir("eval_pfm_gt");
  ImageF32 image(3, 2, 10.5f);
  image(1, 0) = std::numeric_limits<float>::infinity();
  image(2, 0) = -1.0f;
  image(0, 1) = 0.0f;  // zero disparity is a valid (infinitely far) value in PFM
  image(2, 1) = 99.0f;
  const std::string path = dir + "/gt.pfm";
  ASSERT_TRUE(writePfm(path, image).isOk());
  DisparityGroundTruth gt;
  Status s = loadDisparityGroundTruth(path, 1.0, std::nullopt, &gt);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(gt.valid(0, 0), 1);
  EXPECT_EQ(gt.d_px(0, 0), 10.5f);
  EXPECT_EQ(gt.valid(1, 0), 0);
  EXPECT_EQ(gt.valid(2, 0), 0);
  EXPECT_EQ(gt.valid(0, 1), 1);
  EXPECT_EQ(gt.d_px(0, 1), 0.0f);
  EXPECT_EQ(gt.valid(2, 1), 1);
  // An explicit invalid value applies to PFM too, and the scale divides.
  s = loadDisparityGroundTruth(path, 2.0, 99.0, &gt);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(gt.valid(2, 1), 0);
  EXPECT_EQ(gt.d_px(0, 0), 5.25f);
}

TEST(DisparityIo, CorruptPfmFilesGiveErrorsNamingThePath) {
  const std::string dir = test::makeTempDir("eval_pfm_corrupt");
  const std::string good = handMadePfm(true);
  struct Case {
    const char* name;
    std::string bytes;
    const char* expect;  // part of the message
  };
  const std::vector<Case> cases = {
      {"truncated", good.substr(0, good.size() - 3), "truncated"},
      {"trailing", good + "xyz", "trailing"},
      {"colour", "PF\n1 1\n-1\n" + std::string(12, '\0'), "three-channel"},
      {"magic", "P5\n1 1\n255\n" + std::string(1, '\0'), "not a PFM"},
      {"width", "Pf\nab 2\n-1\n" + std::string(16, '\0'), "width height"},
      {"zero", "Pf\n0 2\n-1\n", "out of range"},
      {"huge", "Pf\n100000000 100000000\n-1\n", "out of range"},
      {"scale0", "Pf\n1 1\n0\n" + std::string(4, '\0'), "scale"},
      {"scalenan", "Pf\n1 1\nnan\n" + std::string(4, '\0'), "scale"},
      {"noscale", "Pf\n1 1\n", "scale"},
      {"unterminated", "Pf\n1 1\n-1", "truncated"},
      {"empty", "", "not a PFM"},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.name + ".pfm";
    writeBytes(path, c.bytes);
    ImageF32 image;
    const Status s = readPfm(path, &image);
    ASSERT_FALSE(s.isOk()) << c.name;
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
    EXPECT_NE(s.message().find(c.expect), std::string::npos) << c.name << ": " << s.message();
  }
  // The ground-truth loader sees the same PFM errors (format detected from the magic bytes).
  DisparityGroundTruth gt;
  EXPECT_FALSE(loadDisparityGroundTruth(dir + "/truncated.pfm", 1.0, std::nullopt, &gt).isOk());
  EXPECT_FALSE(loadDisparityGroundTruth(dir + "/colour.pfm", 1.0, std::nullopt, &gt).isOk());
}

TEST(DisparityIo, WritePfmRejectsEmptyImageAndUnwritablePath) {
  const std::string dir = test::makeTempDir("eval_pfm_write");
  EXPECT_FALSE(writePfm(dir + "/empty.pfm", ImageF32()).isOk());
  ImageF32 broken(3, 3);
  broken.data.resize(4);
  EXPECT_FALSE(writePfm(dir + "/broken.pfm", broken).isOk());
  const Status s = writePfm(dir + "/no/such/dir/x.pfm", ImageF32(2, 2));
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("no/such/dir"), std::string::npos) << s.message();
}

// ---------------------------------------------------------------------------------------------
// Integer PNG / PGM

TEST(DisparityIo, EightBitPgmDividesByScaleAndZeroIsInvalid) {
  const std::string dir = test::makeTempDir("eval_pgm8");
  cv::Mat raw(2, 3, CV_8UC1);
  raw.at<uint8_t>(0, 0) = 0;
  raw.at<uint8_t>(0, 1) = 16;
  raw.at<uint8_t>(0, 2) = 80;
  raw.at<uint8_t>(1, 0) = 224;
  raw.at<uint8_t>(1, 1) = 255;
  raw.at<uint8_t>(1, 2) = 1;
  const std::string path = dir + "/disp.pgm";
  ASSERT_TRUE(cv::imwrite(path, raw));
  DisparityGroundTruth gt;
  Status s = loadDisparityGroundTruth(path, 16.0, std::nullopt, &gt);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_EQ(gt.d_px.width, 3);
  ASSERT_EQ(gt.d_px.height, 2);
  EXPECT_EQ(gt.valid(0, 0), 0);
  EXPECT_EQ(gt.d_px(0, 0), 0.0f);
  EXPECT_EQ(gt.valid(1, 0), 1);
  EXPECT_NEAR(gt.d_px(1, 0), 1.0f, kExactF);
  EXPECT_NEAR(gt.d_px(2, 0), 5.0f, kExactF);
  EXPECT_NEAR(gt.d_px(0, 1), 14.0f, kExactF);
  EXPECT_NEAR(gt.d_px(1, 1), 255.0f / 16.0f, kExactF);
  EXPECT_NEAR(gt.d_px(2, 1), 1.0f / 16.0f, kExactF);
  // An explicit invalid value 255 adds to 0, it does not replace it: the map's unknown pixels
  // (raw 0) stay unknown instead of becoming a valid zero disparity.
  s = loadDisparityGroundTruth(path, 16.0, 255.0, &gt);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(gt.valid(0, 0), 0);
  EXPECT_EQ(gt.valid(1, 1), 0);
  EXPECT_EQ(gt.valid(1, 0), 1);
}

TEST(DisparityIo, SixteenBitPngAndPgmKeepFullRange) {
  const std::string dir = test::makeTempDir("eval_png16");
  cv::Mat raw(1, 4, CV_16UC1);
  raw.at<uint16_t>(0, 0) = 0;
  raw.at<uint16_t>(0, 1) = 256;
  raw.at<uint16_t>(0, 2) = 12345;
  raw.at<uint16_t>(0, 3) = 65535;
  for (const char* ext : {".png", ".pgm"}) {
    const std::string path = dir + "/disp" + ext;
    ASSERT_TRUE(cv::imwrite(path, raw));
    DisparityGroundTruth gt;
    const Status s = loadDisparityGroundTruth(path, 256.0, std::nullopt, &gt);  // KITTI coding
    ASSERT_TRUE(s.isOk()) << s.message();
    EXPECT_EQ(gt.valid(0, 0), 0) << ext;
    EXPECT_NEAR(gt.d_px(1, 0), 1.0f, kExactF) << ext;
    EXPECT_NEAR(gt.d_px(2, 0), 12345.0f / 256.0f, kExactF) << ext;
    EXPECT_NEAR(gt.d_px(3, 0), 65535.0f / 256.0f, kExactF) << ext;
  }
}

TEST(DisparityIo, BadIntegerFilesAndArgumentsGiveErrors) {
  const std::string dir = test::makeTempDir("eval_int_bad");
  cv::Mat raw(40, 50, CV_8UC1);
  cv::randu(raw, 0, 256);  // cv::theRNG's fixed default seed
  const std::string pgm = dir + "/d.pgm";
  const std::string png = dir + "/d.png";
  ASSERT_TRUE(cv::imwrite(pgm, raw));
  ASSERT_TRUE(cv::imwrite(png, raw));
  const std::string pgm_bytes = readBytes(pgm);
  const std::string png_bytes = readBytes(png);
  writeBytes(dir + "/short.pgm", pgm_bytes.substr(0, pgm_bytes.size() / 2));
  writeBytes(dir + "/short.png", png_bytes.substr(0, png_bytes.size() / 2));
  writeBytes(dir + "/garbage.png", "this is not an image");
  writeBytes(dir + "/empty.pgm", "");
  cv::Mat colour(4, 4, CV_8UC3, cv::Scalar(1, 2, 3));
  ASSERT_TRUE(cv::imwrite(dir + "/colour.png", colour));

  DisparityGroundTruth gt;
  for (const char* name :
       {"/short.pgm", "/short.png", "/garbage.png", "/empty.pgm", "/colour.png", "/missing.pgm"}) {
    const std::string path = dir + name;
    const Status s = loadDisparityGroundTruth(path, 1.0, std::nullopt, &gt);
    EXPECT_FALSE(s.isOk()) << name;
    EXPECT_NE(s.message().find(path), std::string::npos) << s.message();
  }
  EXPECT_FALSE(loadDisparityGroundTruth(dir, 1.0, std::nullopt, &gt).isOk()) << "a directory";
  EXPECT_FALSE(loadDisparityGroundTruth(pgm, 0.0, std::nullopt, &gt).isOk());
  EXPECT_FALSE(loadDisparityGroundTruth(pgm, -16.0, std::nullopt, &gt).isOk());
  EXPECT_FALSE(loadDisparityGroundTruth(pgm, std::nan(""), std::nullopt, &gt).isOk());
  EXPECT_FALSE(loadDisparityGroundTruth(pgm, 1.0, std::nan(""), &gt).isOk());
  EXPECT_TRUE(loadDisparityGroundTruth(pgm, 1.0, std::nullopt, &gt).isOk());
}

// ---------------------------------------------------------------------------------------------
// Masks

TEST(DisparityIo, MaskKeepsStoredValuesAndRejectsOtherTypes) {
  const std::string dir = test::makeTempDir("eval_mask");
  cv::Mat m(2, 2, CV_8UC1);
  m.at<uint8_t>(0, 0) = 255;
  m.at<uint8_t>(0, 1) = 128;
  m.at<uint8_t>(1, 0) = 0;
  m.at<uint8_t>(1, 1) = 255;
  ASSERT_TRUE(cv::imwrite(dir + "/nonocc.png", m));
  ImageU8 mask;
  const Status s = loadMask(dir + "/nonocc.png", &mask);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(mask(0, 0), 255);
  EXPECT_EQ(mask(1, 0), 128);
  EXPECT_EQ(mask(0, 1), 0);
  EXPECT_EQ(mask(1, 1), 255);

  ASSERT_TRUE(cv::imwrite(dir + "/wide.png", cv::Mat(2, 2, CV_16UC1, cv::Scalar(255))));
  Status bad = loadMask(dir + "/wide.png", &mask);
  EXPECT_FALSE(bad.isOk());
  EXPECT_NE(bad.message().find("wide.png"), std::string::npos) << bad.message();
  bad = loadMask(dir + "/missing.png", &mask);
  EXPECT_FALSE(bad.isOk());
  EXPECT_NE(bad.message().find("missing.png"), std::string::npos) << bad.message();
}

// ---------------------------------------------------------------------------------------------
// Real Middlebury ground truth

TEST(DisparityIo, TsukubaGroundTruthHasDocumentedRange) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  DisparityGroundTruth gt;
  const Status s =
      loadDisparityGroundTruth(data + "/middlebury/tsukuba/disp3.pgm", 16.0, std::nullopt, &gt);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_EQ(gt.d_px.width, 384);
  ASSERT_EQ(gt.d_px.height, 288);
  float lo = std::numeric_limits<float>::max();
  float hi = std::numeric_limits<float>::lowest();
  int64_t valid = 0;
  for (size_t i = 0; i < gt.d_px.data.size(); ++i) {
    if (gt.valid.data[i] == 0) continue;
    ++valid;
    lo = std::min(lo, gt.d_px.data[i]);
    hi = std::max(hi, gt.d_px.data[i]);
  }
  EXPECT_EQ(lo, 5.0f);
  EXPECT_EQ(hi, 14.0f);
  // Exactly the unknown 18-px border is invalid (data README).
  constexpr int kBorderPx = 18;
  for (int v = 0; v < gt.d_px.height; ++v) {
    for (int u = 0; u < gt.d_px.width; ++u) {
      const bool inside =
          u >= kBorderPx && v >= kBorderPx && u < 384 - kBorderPx && v < 288 - kBorderPx;
      ASSERT_EQ(gt.valid(u, v), inside ? 1 : 0) << u << "," << v;
    }
  }
  EXPECT_EQ(valid, static_cast<int64_t>(384 - 2 * kBorderPx) * (288 - 2 * kBorderPx));
}

TEST(DisparityIo, VenusGroundTruthHasPlausibleRange) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  DisparityGroundTruth gt;
  const Status s =
      loadDisparityGroundTruth(data + "/middlebury/venus/disp2.pgm", 8.0, std::nullopt, &gt);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_EQ(gt.d_px.width, 434);
  ASSERT_EQ(gt.d_px.height, 383);
  float lo = std::numeric_limits<float>::max();
  float hi = std::numeric_limits<float>::lowest();
  for (size_t i = 0; i < gt.d_px.data.size(); ++i) {
    if (gt.valid.data[i] == 0) continue;
    lo = std::min(lo, gt.d_px.data[i]);
    hi = std::max(hi, gt.d_px.data[i]);
  }
  // README: search 0..20 px; the file's values are 24..158, i.e. 3..19.75 px.
  EXPECT_EQ(lo, 3.0f);
  EXPECT_EQ(hi, 19.75f);
}

// ---------------------------------------------------------------------------------------------
// Ground truth from simulator depth

StereoRig testRig() {
  StereoRig rig;
  rig.fx_px = 400.0;
  rig.baseline_m = 0.1;
  return rig;
}

TEST(DisparityFromDepth, StepInvalidatesOnlyTheColumnsAtTheStep) {
  const StereoRig rig = testRig();
  ImageF32 depth(10, 6);
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) depth(u, v) = u < 5 ? 2.0f : 4.0f;
  }
  DisparityGroundTruth gt;
  const Status s = disparityFromDepth(depth, rig, &gt);
  ASSERT_TRUE(s.isOk()) << s.message();
  for (int v = 0; v < depth.height; ++v) {
    for (int u = 0; u < depth.width; ++u) {
      const bool at_step = u == 4 || u == 5;
      EXPECT_EQ(gt.valid(u, v), at_step ? 0 : 1) << u << "," << v;
      if (at_step) continue;
      const double expected = rig.fx_px * rig.baseline_m / depth(u, v);
      EXPECT_NEAR(gt.d_px(u, v), expected, kFloatRelTol * expected);
    }
  }
}

TEST(DisparityFromDepth, ThresholdIsFivePercentOfTheNearestDepth) {
  const StereoRig rig = testRig();
  // Two half-planes whose depth ratio is just below / just above 1 + 5 %.
  for (const auto& [ratio, expect_valid] :
       {std::pair{1.0 + 0.9 * kDepthDiscontinuityRelSpan, true},
        std::pair{1.0 + 1.1 * kDepthDiscontinuityRelSpan, false}}) {
    ImageF32 depth(6, 3);
    for (int v = 0; v < 3; ++v) {
      for (int u = 0; u < 6; ++u) depth(u, v) = static_cast<float>(u < 3 ? 3.0 : 3.0 * ratio);
    }
    DisparityGroundTruth gt;
    ASSERT_TRUE(disparityFromDepth(depth, rig, &gt).isOk());
    EXPECT_EQ(gt.valid(2, 1), expect_valid ? 1 : 0) << ratio;
    EXPECT_EQ(gt.valid(3, 1), expect_valid ? 1 : 0) << ratio;
    EXPECT_EQ(gt.valid(0, 1), 1) << ratio;
    EXPECT_EQ(gt.valid(5, 1), 1) << ratio;
  }
}

TEST(DisparityFromDepth, HolesInvalidateThemselvesAndTheirNeighboursButNotTheBorder) {
  const StereoRig rig = testRig();
  ImageF32 depth(7, 7, 5.0f);
  depth(3, 3) = 0.0f;                                     // no surface
  depth(6, 0) = std::numeric_limits<float>::quiet_NaN();  // corrupt value
  DisparityGroundTruth gt;
  ASSERT_TRUE(disparityFromDepth(depth, rig, &gt).isOk());
  int invalid = 0;
  for (int v = 0; v < 7; ++v) {
    for (int u = 0; u < 7; ++u) {
      const bool near_hole = std::abs(u - 3) <= 1 && std::abs(v - 3) <= 1;
      const bool near_nan = u >= 5 && v <= 1;
      EXPECT_EQ(gt.valid(u, v), near_hole || near_nan ? 0 : 1) << u << "," << v;
      invalid += gt.valid(u, v) == 0 ? 1 : 0;
    }
  }
  EXPECT_EQ(invalid, 9 + 4);
  // Image corners (partial neighbourhoods) on a flat surface are valid.
  EXPECT_EQ(gt.valid(0, 0), 1);
  EXPECT_EQ(gt.valid(0, 6), 1);
  EXPECT_EQ(gt.valid(6, 6), 1);
}

TEST(DisparityFromDepth, SlantedPlaneStaysValid) {
  const StereoRig rig = testRig();
  // Depth growing 1 % per pixel: a steep slant, but a 3x3 window spans only ~2 %.
  ImageF32 depth(20, 4);
  for (int v = 0; v < 4; ++v) {
    for (int u = 0; u < 20; ++u) depth(u, v) = static_cast<float>(2.0 * std::pow(1.01, u));
  }
  DisparityGroundTruth gt;
  ASSERT_TRUE(disparityFromDepth(depth, rig, &gt).isOk());
  for (uint8_t valid : gt.valid.data) EXPECT_EQ(valid, 1);
}

TEST(DisparityFromDepth, BadInputGivesErrors) {
  DisparityGroundTruth gt;
  EXPECT_FALSE(disparityFromDepth(ImageF32(), testRig(), &gt).isOk());
  StereoRig rig = testRig();
  rig.baseline_m = 0.0;
  Status s = disparityFromDepth(ImageF32(4, 4, 1.0f), rig, &gt);
  EXPECT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("baseline_m"), std::string::npos) << s.message();
  rig = testRig();
  rig.fx_px = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(disparityFromDepth(ImageF32(4, 4, 1.0f), rig, &gt).isOk());
  ImageF32 inconsistent(4, 4, 1.0f);
  inconsistent.data.pop_back();
  EXPECT_FALSE(disparityFromDepth(inconsistent, testRig(), &gt).isOk());
}

// ---------------------------------------------------------------------------------------------
// Occlusion from the left ground truth

TEST(NonOccludedMask, NearSurfaceHidesTheBackgroundToItsLeftAndTheEdgeIsOccluded) {
  // One row: background d = 2 at u < 10, a nearer box d = 6 at u >= 10. The right camera sees
  // the box shifted 6 px and the background 2 px: background pixels u in [7, 10) land at
  // u - 2 in [5, 8), at least half a pixel right of the box's leftmost landing 10 - 6 = 4, so
  // the box hides them (u = 6 lands exactly on the box's edge and stays visible). Pixels u < 2
  // land left of the right image.
  constexpr int kW = 20;
  DisparityGroundTruth gt{ImageF32(kW, 1), ImageU8(kW, 1, 1)};
  for (int u = 0; u < kW; ++u) gt.d_px(u, 0) = u < 10 ? 2.0f : 6.0f;
  gt.valid(15, 0) = 0;  // unknown: neither evaluated nor hiding anything
  ImageU8 mask;
  nonOccludedMask(gt, &mask);
  ASSERT_EQ(mask.width, kW);
  for (int u = 0; u < kW; ++u) {
    uint8_t expected = 255;
    if (u < 2 || (u >= 7 && u < 10)) expected = 128;
    if (u == 15) expected = 0;
    EXPECT_EQ(mask(u, 0), expected) << "u = " << u;
  }
}

TEST(NonOccludedMask, TsukubaOccludesAFewPercent) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  DisparityGroundTruth gt;
  ASSERT_TRUE(
      loadDisparityGroundTruth(data + "/middlebury/tsukuba/disp3.pgm", 16.0, std::nullopt, &gt)
          .isOk());
  ImageU8 mask;
  nonOccludedMask(gt, &mask);
  size_t valid = 0;
  size_t visible = 0;
  for (size_t i = 0; i < mask.data.size(); ++i) {
    valid += gt.valid.data[i] != 0 ? 1 : 0;
    visible += mask.data[i] == 255 ? 1 : 0;
  }
  // Tsukuba has narrow occlusions at the left of each foreground object (a few px wide).
  const double occluded_pct = 100.0 * static_cast<double>(valid - visible) / valid;
  EXPECT_GT(occluded_pct, 1.0);
  EXPECT_LT(occluded_pct, 6.0);
}

}  // namespace
}  // namespace twocam::eval
