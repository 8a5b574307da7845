// RawlogReader on rawlogs that TwoCam did not write: logs built here with MRPT's own API in the
// sensory-frame and observations-only formats, with other tools' labels and clocks, and broken
// logs (missing, truncated, garbage, inconsistent calibration, missing images).

#include <gtest/gtest.h>
#include <mrpt/core/Clock.h>
#include <mrpt/img/CImage.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CActionRobotMovement2D.h>
#include <mrpt/obs/CObservationComment.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <mrpt/obs/CRawlog.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DQuat.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "io/rawlog.h"
#include "support/test_paths.h"

namespace twocam::io {
namespace {

namespace fs = std::filesystem;

// Intrinsics, baseline and poses are stored as doubles (CPose3DQuat: quaternion round trip).
constexpr double kPoseTol = 1e-9;
// Odometry composed from increments: a few double products.
constexpr double kOdometryTol = 1e-12;
// MRPT stores time in 100 ns ticks.
constexpr int64_t kTickNs = 100;
// Clock::fromDouble goes through a double of ~1.7e9 s: ~0.2 us resolution.
constexpr int64_t kDoubleClockTolNs = 1000;

constexpr int kWidth = 40;
constexpr int kHeight = 30;

/// MRPT time point for a TwoCam-style t_ns (ticks since MRPT's epoch).
mrpt::Clock::time_point ticksTime(int64_t t_ns) {
  return mrpt::Clock::time_point(mrpt::Clock::duration(t_ns / kTickNs));
}

cv::Mat pattern(int width, int height, int seed, int channels = 1) {
  cv::Mat m(height, width, channels == 1 ? CV_8UC1 : CV_8UC3);
  std::mt19937 rng(static_cast<uint32_t>(seed));
  for (int v = 0; v < height; ++v) {
    auto* row = m.ptr<uint8_t>(v);
    for (int i = 0; i < width * channels; ++i) row[i] = static_cast<uint8_t>(rng() & 0xFF);
  }
  return m;
}

/// A smooth colour image (JPEG keeps it to within a few grey levels).
cv::Mat smoothColour(int width, int height, int seed) {
  cv::Mat m(height, width, CV_8UC3);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
      m.at<cv::Vec3b>(v, u) = cv::Vec3b(static_cast<uint8_t>(40 + 3 * u + seed),
                                        static_cast<uint8_t>(60 + 4 * v),
                                        static_cast<uint8_t>(100 + 2 * (u + v)));
  return m;
}

struct ForeignRig {
  double fx = 45.0, fy = 46.0, cx = 19.5, cy = 14.25, baseline_m = 0.2;
  mrpt::poses::CPose3D camera_pose =
      mrpt::poses::CPose3D(0.3, -0.1, 0.5, -M_PI / 2, 0.0, -M_PI / 2 - 0.1);
};

mrpt::img::TCamera camera(const ForeignRig& rig, int width, int height) {
  mrpt::img::TCamera c;
  c.ncols = static_cast<uint32_t>(width);
  c.nrows = static_cast<uint32_t>(height);
  c.setIntrinsicParamsFromValues(rig.fx, rig.fy, rig.cx, rig.cy);
  return c;
}

/// A rectified stereo observation with embedded images (or none when width == 0, for
/// external-image tests that fill them in).
mrpt::obs::CObservationStereoImages::Ptr stereoObs(const ForeignRig& rig,
                                                   mrpt::Clock::time_point t,
                                                   const std::string& label,
                                                   int seed,
                                                   int channels = 1) {
  auto obs = std::make_shared<mrpt::obs::CObservationStereoImages>();
  obs->sensorLabel = label;
  obs->timestamp = t;
  obs->leftCamera = camera(rig, kWidth, kHeight);
  obs->rightCamera = obs->leftCamera;
  obs->cameraPose = mrpt::poses::CPose3DQuat(rig.camera_pose);
  obs->rightCameraPose =
      mrpt::poses::CPose3DQuat(mrpt::poses::CPose3D(rig.baseline_m, 0, 0, 0, 0, 0));
  obs->imageLeft =
      mrpt::img::CImage(pattern(kWidth, kHeight, seed, channels), mrpt::img::DEEP_COPY);
  obs->imageRight =
      mrpt::img::CImage(pattern(kWidth, kHeight, seed + 1000, channels), mrpt::img::DEEP_COPY);
  obs->hasImageRight = true;
  return obs;
}

mrpt::obs::CObservationOdometry::Ptr odometryObs(mrpt::Clock::time_point t,
                                                 const std::string& label,
                                                 const mrpt::poses::CPose2D& p) {
  auto obs = std::make_shared<mrpt::obs::CObservationOdometry>();
  obs->sensorLabel = label;
  obs->timestamp = t;
  obs->odometry = p;
  return obs;
}

ImageU8 toImage(const cv::Mat& m) {
  ImageU8 img(m.cols, m.rows);
  for (int v = 0; v < m.rows; ++v)
    for (int u = 0; u < m.cols; ++u) img(u, v) = m.at<uint8_t>(v, u);
  return img;
}

/// Writes objects in the observations-only format (a plain, uncompressed stream, as MRPT tools
/// do when compression is off).
void writeObservations(const std::string& path,
                       const std::vector<mrpt::serialization::CSerializable::Ptr>& objects) {
  mrpt::io::CFileOutputStream f(path);
  ASSERT_TRUE(f.fileOpenCorrectly()) << path;
  auto arch = mrpt::serialization::archiveFrom(f);
  for (const auto& o : objects) arch << *o;
}

std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Reads a log to its end; returns the frames and the final status.
struct ReadResult {
  Status open;
  Status end;
  std::vector<LogFrame> frames;
  StereoRig rig;
};
ReadResult readAll(const std::string& path) {
  ReadResult r;
  std::unique_ptr<RawlogReader> reader;
  r.open = RawlogReader::open(path, &reader);
  if (!r.open) return r;
  r.rig = reader->rig();
  LogFrame f;
  while (reader->next(&f, &r.end)) r.frames.push_back(f);
  return r;
}

void expectRig(const StereoRig& got, const ForeignRig& want) {
  EXPECT_EQ(got.width_px, kWidth);
  EXPECT_EQ(got.height_px, kHeight);
  EXPECT_NEAR(got.fx_px, want.fx, kPoseTol);
  EXPECT_NEAR(got.fy_px, want.fy, kPoseTol);
  EXPECT_NEAR(got.cx_px, want.cx, kPoseTol);
  EXPECT_NEAR(got.cy_px, want.cy, kPoseTol);
  EXPECT_NEAR(got.baseline_m, want.baseline_m, kPoseTol);
  const auto M = want.camera_pose.getHomogeneousMatrixVal<mrpt::math::CMatrixDouble44>();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(got.T_b_cl.matrix()(r, c), M(r, c), kPoseTol) << r << "," << c;
}

#define TWOCAM_EXPECT_MESSAGE_HAS(status, text) \
  EXPECT_NE((status).message().find(text), std::string::npos) << "message: " << (status).message()

// --- (a) sensory-frame rawlogs ---------------------------------------------------------------

// CActionCollection + CSensoryFrame pairs, embedded images (one frame in colour), wheel odometry
// as CActionRobotMovement2D increments: the reader composes them into accumulated odometry.
TEST(ForeignRawlog, SensoryFrameLogWithEmbeddedImagesAndOdometryActions) {
  const std::string dir = test::makeTempDir("foreign_sf_actions");
  const std::string path = dir + "/sf.rawlog";
  const ForeignRig rig;
  const mrpt::poses::CPose2D increment(0.1, 0.02, 0.05);
  constexpr int kFrames = 4;
  std::vector<int64_t> stamps;
  {
    mrpt::obs::CRawlog log;
    for (int k = 0; k < kFrames; ++k) {
      const int64_t t = 5'000'000'000LL + k * 50'000'000LL;
      stamps.push_back(t);
      mrpt::obs::CActionCollection acts;
      mrpt::obs::CActionRobotMovement2D mv;
      mv.computeFromOdometry(k == 0 ? mrpt::poses::CPose2D() : increment,
                             mrpt::obs::CActionRobotMovement2D::TMotionModelOptions());
      mv.timestamp = ticksTime(t);
      acts.insert(mv);
      log.insert(acts);
      mrpt::obs::CSensoryFrame sf;
      sf.insert(stereoObs(rig, ticksTime(t), "STEREO_CAM", k, k == 2 ? 3 : 1));
      log.insert(sf);
    }
    ASSERT_TRUE(log.saveToRawLogFile(path));
  }
  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_TRUE(r.end.isOk()) << r.end.message();
  ASSERT_EQ(r.frames.size(), static_cast<size_t>(kFrames));
  expectRig(r.rig, rig);
  mrpt::poses::CPose2D expected;
  for (int k = 0; k < kFrames; ++k) {
    const LogFrame& f = r.frames[k];
    EXPECT_EQ(f.index, k);
    EXPECT_EQ(f.stereo.t_ns, stamps[k]);
    if (k > 0) expected = expected + increment;
    ASSERT_TRUE(f.odometry.has_value()) << "frame " << k;
    EXPECT_EQ(f.odometry->t_ns, stamps[k]);
    EXPECT_NEAR(f.odometry->pose.x_m, expected.x(), kOdometryTol) << k;
    EXPECT_NEAR(f.odometry->pose.y_m, expected.y(), kOdometryTol) << k;
    EXPECT_NEAR(f.odometry->pose.yaw_rad, expected.phi(), kOdometryTol) << k;
    EXPECT_FALSE(f.ground_truth.has_value());
    ASSERT_EQ(f.stereo.left.width, kWidth);
    ASSERT_EQ(f.stereo.right.height, kHeight);
    if (k != 2) {
      EXPECT_EQ(f.stereo.left.data, toImage(pattern(kWidth, kHeight, k)).data) << k;
      EXPECT_EQ(f.stereo.right.data, toImage(pattern(kWidth, kHeight, k + 1000)).data) << k;
    }
  }
}

// Sensory frames whose odometry is a CObservationOdometry inside the frame (no actions), with
// the stamp of the stereo pair; the last frame's odometry has another stamp and is not attached.
TEST(ForeignRawlog, SensoryFrameLogWithOdometryObservations) {
  const std::string dir = test::makeTempDir("foreign_sf_odometry");
  const std::string path = dir + "/sf.rawlog";
  const ForeignRig rig;
  {
    mrpt::obs::CRawlog log;
    for (int k = 0; k < 3; ++k) {
      const int64_t t = 2'000'000'000LL + k * 100'000'000LL;
      mrpt::obs::CActionCollection empty;
      log.insert(empty);
      mrpt::obs::CSensoryFrame sf;
      const int64_t t_odo = k == 2 ? t + 10'000'000LL : t;
      sf.insert(
          odometryObs(ticksTime(t_odo), "ODOM", mrpt::poses::CPose2D(1.0 * k, -0.5 * k, 0.1 * k)));
      sf.insert(stereoObs(rig, ticksTime(t), "STEREO_CAM", k));
      log.insert(sf);
    }
    ASSERT_TRUE(log.saveToRawLogFile(path));
  }
  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_TRUE(r.end.isOk()) << r.end.message();
  ASSERT_EQ(r.frames.size(), 3u);
  for (int k = 0; k < 2; ++k) {
    ASSERT_TRUE(r.frames[k].odometry.has_value()) << k;
    EXPECT_NEAR(r.frames[k].odometry->pose.x_m, 1.0 * k, kOdometryTol);
    EXPECT_NEAR(r.frames[k].odometry->pose.y_m, -0.5 * k, kOdometryTol);
    EXPECT_NEAR(r.frames[k].odometry->pose.yaw_rad, 0.1 * k, kOdometryTol);
  }
  EXPECT_FALSE(r.frames[2].odometry.has_value())
      << "odometry 10 ms off the frame's stamp must not be attached";
}

// --- (b) observations-only rawlogs from another tool ------------------------------------------

// Labels "CAMERA1" / "ODOM", real-clock MRPT stamps (mrpt::Clock since 1601, as
// rawlog-grabber writes them), odometry written before the stereo pair, odometry samples
// between frames, a second stereo camera "CAMERA2" with another calibration (skipped), and
// external images in MRPT's default "Images/" folder.
TEST(ForeignRawlog, ObservationsOnlyLogFromAnotherTool) {
  const std::string dir = test::makeTempDir("foreign_obs_only");
  const std::string path = dir + "/grabbed.rawlog";
  fs::create_directories(dir + "/Images");
  const ForeignRig rig;
  ForeignRig other;
  other.fx = 80.0;
  other.baseline_m = 0.07;
  const double t0_s = 1'700'000'000.25;  // 2023, UNIX epoch
  constexpr int kFrames = 3;
  std::vector<mrpt::serialization::CSerializable::Ptr> objects;
  std::vector<mrpt::Clock::time_point> stamps;
  for (int k = 0; k < kFrames; ++k) {
    const auto t = mrpt::Clock::fromDouble(t0_s + 0.1 * k);
    stamps.push_back(t);
    if (k != 1)
      objects.push_back(odometryObs(t, "ODOM", mrpt::poses::CPose2D(0.2 * k, 0.01 * k, -0.03 * k)));
    auto s = stereoObs(rig, t, "CAMERA1", k);
    const std::string left = "CAMERA1_L_" + std::to_string(k) + ".png";
    const std::string right = "CAMERA1_R_" + std::to_string(k) + ".png";
    ASSERT_TRUE(cv::imwrite(dir + "/Images/" + left, pattern(kWidth, kHeight, k)));
    ASSERT_TRUE(cv::imwrite(dir + "/Images/" + right, pattern(kWidth, kHeight, k + 1000)));
    s->imageLeft.setExternalStorage(left);
    s->imageRight.setExternalStorage(right);
    objects.push_back(s);
    objects.push_back(stereoObs(other, t, "CAMERA2", 50 + k));
    // A faster odometry stream: a sample half-way to the next frame belongs to no frame.
    objects.push_back(odometryObs(
        mrpt::Clock::fromDouble(t0_s + 0.1 * k + 0.05), "ODOM", mrpt::poses::CPose2D(9, 9, 0)));
  }
  writeObservations(path, objects);

  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_TRUE(r.end.isOk()) << r.end.message();
  ASSERT_EQ(r.frames.size(), static_cast<size_t>(kFrames));
  expectRig(r.rig, rig);
  for (int k = 0; k < kFrames; ++k) {
    const LogFrame& f = r.frames[k];
    // Real-clock stamps come back as UNIX-epoch nanoseconds.
    const auto expected_ns = static_cast<int64_t>(std::llround((t0_s + 0.1 * k) * 1e9));
    EXPECT_NEAR(
        static_cast<double>(f.stereo.t_ns), static_cast<double>(expected_ns), kDoubleClockTolNs)
        << k;
    EXPECT_EQ(f.stereo.left.data, toImage(pattern(kWidth, kHeight, k)).data) << k;
    EXPECT_EQ(f.stereo.right.data, toImage(pattern(kWidth, kHeight, k + 1000)).data) << k;
    if (k == 1) {
      EXPECT_FALSE(f.odometry.has_value());
      continue;
    }
    ASSERT_TRUE(f.odometry.has_value()) << k;
    EXPECT_EQ(f.odometry->t_ns, f.stereo.t_ns);
    EXPECT_NEAR(f.odometry->pose.x_m, 0.2 * k, kOdometryTol);
    EXPECT_NEAR(f.odometry->pose.y_m, 0.01 * k, kOdometryTol);
    EXPECT_NEAR(f.odometry->pose.yaw_rad, -0.03 * k, kOdometryTol);
  }
  EXPECT_GT(r.frames[1].stereo.t_ns, r.frames[0].stereo.t_ns);
}

// --- Bad input ---------------------------------------------------------------------------------

TEST(ForeignRawlogErrors, MissingFile) {
  const std::string path = test::makeTempDir("foreign_missing") + "/nothing.rawlog";
  const ReadResult r = readAll(path);
  ASSERT_FALSE(r.open.isOk());
  TWOCAM_EXPECT_MESSAGE_HAS(r.open, path);
  TWOCAM_EXPECT_MESSAGE_HAS(r.open, "no such file");
}

TEST(ForeignRawlogErrors, RandomGarbage) {
  const std::string dir = test::makeTempDir("foreign_garbage");
  for (int seed = 0; seed < 20; ++seed) {
    const std::string path = dir + "/garbage" + std::to_string(seed) + ".rawlog";
    std::mt19937 rng(static_cast<uint32_t>(seed));
    std::string bytes(1000 + 500 * seed, '\0');
    for (auto& b : bytes) b = static_cast<char>(rng() & 0xFF);
    writeBytes(path, bytes);
    const ReadResult r = readAll(path);
    ASSERT_FALSE(r.open.isOk()) << "seed " << seed;
    TWOCAM_EXPECT_MESSAGE_HAS(r.open, path);
  }
}

// A valid observation followed by garbage: with only a header (a comment) before it the log has
// no readable stereo pair; with a whole frame before it, frame 0 reads and frame 1 is an error.
TEST(ForeignRawlogErrors, ValidStartThenGarbage) {
  const std::string dir = test::makeTempDir("foreign_header_garbage");
  const ForeignRig rig;
  auto comment = std::make_shared<mrpt::obs::CObservationComment>();
  comment->text = "recorded by another tool";
  comment->timestamp = ticksTime(1'000'000'000LL);
  for (int seed = 0; seed < 10; ++seed) {
    std::mt19937 rng(static_cast<uint32_t>(100 + seed));
    std::string garbage(3000, '\0');
    for (auto& b : garbage) b = static_cast<char>(rng() & 0xFF);

    const std::string header_only = dir + "/header" + std::to_string(seed) + ".rawlog";
    writeObservations(header_only, {comment});
    writeBytes(header_only, readBytes(header_only) + garbage);
    const ReadResult h = readAll(header_only);
    ASSERT_FALSE(h.open.isOk()) << "seed " << seed;
    TWOCAM_EXPECT_MESSAGE_HAS(h.open, header_only);

    const std::string one_frame = dir + "/frame" + std::to_string(seed) + ".rawlog";
    writeObservations(one_frame, {comment, stereoObs(rig, ticksTime(1'000'000'000LL), "CAM", 1)});
    writeBytes(one_frame, readBytes(one_frame) + garbage);
    const ReadResult f = readAll(one_frame);
    ASSERT_TRUE(f.open.isOk()) << f.open.message();
    EXPECT_EQ(f.frames.size(), 1u);
    ASSERT_FALSE(f.end.isOk()) << "seed " << seed << ": garbage after a frame must not end cleanly";
    TWOCAM_EXPECT_MESSAGE_HAS(f.end, one_frame);
    TWOCAM_EXPECT_MESSAGE_HAS(f.end, "frame 1");
  }
}

// A gzip sensory-frame log with embedded images, cut at several points: never a crash, never a
// clean end with all frames.
TEST(ForeignRawlogErrors, TruncatedGzipLog) {
  const std::string dir = test::makeTempDir("foreign_truncated");
  const std::string path = dir + "/full.rawlog";
  const ForeignRig rig;
  constexpr int kFrames = 5;
  {
    mrpt::obs::CRawlog log;
    for (int k = 0; k < kFrames; ++k) {
      mrpt::obs::CSensoryFrame sf;
      sf.insert(stereoObs(rig, ticksTime(1'000'000'000LL * (k + 1)), "CAM", k));
      log.insert(sf);
    }
    ASSERT_TRUE(log.saveToRawLogFile(path));  // ".rawlog": gzip-compressed by MRPT
  }
  ASSERT_EQ(readAll(path).frames.size(), static_cast<size_t>(kFrames));
  const std::string bytes = readBytes(path);
  ASSERT_GT(bytes.size(), 100u);
  for (const double fraction : {0.1, 0.35, 0.5, 0.75, 0.95}) {
    const std::string cut = dir + "/cut.rawlog";
    writeBytes(cut,
               bytes.substr(0, static_cast<size_t>(fraction * static_cast<double>(bytes.size()))));
    const ReadResult r = readAll(cut);
    if (!r.open.isOk()) {
      TWOCAM_EXPECT_MESSAGE_HAS(r.open, cut);
      continue;
    }
    EXPECT_LT(r.frames.size(), static_cast<size_t>(kFrames)) << fraction;
    EXPECT_FALSE(r.end.isOk()) << "cut at " << fraction << " read " << r.frames.size()
                               << " frames and ended cleanly";
    TWOCAM_EXPECT_MESSAGE_HAS(r.end, cut);
  }
}

TEST(ForeignRawlogErrors, NoStereoObservations) {
  const std::string path = test::makeTempDir("foreign_no_stereo") + "/odometry_only.rawlog";
  writeObservations(
      path,
      {odometryObs(ticksTime(1'000'000'000LL), "ODOM", mrpt::poses::CPose2D(0, 0, 0)),
       odometryObs(ticksTime(1'100'000'000LL), "ODOM", mrpt::poses::CPose2D(0.1, 0, 0))});
  const ReadResult r = readAll(path);
  ASSERT_FALSE(r.open.isOk());
  TWOCAM_EXPECT_MESSAGE_HAS(r.open, path);
  TWOCAM_EXPECT_MESSAGE_HAS(r.open, "no stereo images");
}

TEST(ForeignRawlogErrors, ImagesDoNotMatchTheirCalibration) {
  const std::string dir = test::makeTempDir("foreign_sizes");
  const ForeignRig rig;
  // Frame 1 of each log is broken; frame 0 is fine.
  struct Case {
    const char* name;
    std::function<void(mrpt::obs::CObservationStereoImages&)> break_it;
  };
  const std::vector<Case> cases = {
      {"left_wider",
       [](auto& o) {
         o.imageLeft = mrpt::img::CImage(pattern(kWidth + 8, kHeight, 3), mrpt::img::DEEP_COPY);
       }},
      {"right_taller",
       [](auto& o) {
         o.imageRight = mrpt::img::CImage(pattern(kWidth, kHeight + 2, 3), mrpt::img::DEEP_COPY);
       }},
      {"both_smaller",
       [](auto& o) {
         o.imageLeft = mrpt::img::CImage(pattern(kWidth / 2, kHeight, 3), mrpt::img::DEEP_COPY);
         o.imageRight = mrpt::img::CImage(pattern(kWidth / 2, kHeight, 4), mrpt::img::DEEP_COPY);
       }},
      // The right camera's own calibration agrees with its image, but the pair differs in size.
      {"left_right_differ",
       [](auto& o) {
         o.rightCamera.ncols = kWidth / 2;
         o.imageRight = mrpt::img::CImage(pattern(kWidth / 2, kHeight, 4), mrpt::img::DEEP_COPY);
       }},
  };
  for (const Case& c : cases) {
    const std::string path = dir + "/" + c.name + ".rawlog";
    auto bad = stereoObs(rig, ticksTime(2'000'000'000LL), "CAM", 1);
    c.break_it(*bad);
    writeObservations(path, {stereoObs(rig, ticksTime(1'000'000'000LL), "CAM", 0), bad});
    const ReadResult r = readAll(path);
    ASSERT_TRUE(r.open.isOk()) << c.name << ": " << r.open.message();
    EXPECT_EQ(r.frames.size(), 1u) << c.name;
    ASSERT_FALSE(r.end.isOk()) << c.name;
    TWOCAM_EXPECT_MESSAGE_HAS(r.end, path);
    TWOCAM_EXPECT_MESSAGE_HAS(r.end, "frame 1");
    TWOCAM_EXPECT_MESSAGE_HAS(r.end, "do not match");
  }
  // A first frame that is already inconsistent is reported as frame 0.
  const std::string path = dir + "/first.rawlog";
  auto bad = stereoObs(rig, ticksTime(1'000'000'000LL), "CAM", 1);
  bad->leftCamera.nrows = kHeight * 2;
  bad->rightCamera.nrows = kHeight * 2;
  writeObservations(path, {bad});
  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_TRUE(r.frames.empty());
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, "frame 0");
}

TEST(ForeignRawlogErrors, CalibrationChangesOrIsNotRectified) {
  const std::string dir = test::makeTempDir("foreign_calibration");
  const ForeignRig rig;
  ForeignRig other = rig;
  other.fx = 60.0;
  const std::string changed = dir + "/changed.rawlog";
  writeObservations(changed,
                    {stereoObs(rig, ticksTime(1'000'000'000LL), "CAM", 0),
                     stereoObs(other, ticksTime(2'000'000'000LL), "CAM", 1)});
  ReadResult r = readAll(changed);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_EQ(r.frames.size(), 1u);
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, changed);
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, "frame 1");
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, "calibration differs");

  const std::string raw = dir + "/raw.rawlog";
  auto distorted = stereoObs(rig, ticksTime(1'000'000'000LL), "CAM", 0);
  distorted->leftCamera.dist[0] = -0.28;
  writeObservations(raw, {distorted});
  r = readAll(raw);
  ASSERT_FALSE(r.open.isOk());
  TWOCAM_EXPECT_MESSAGE_HAS(r.open, raw);
  TWOCAM_EXPECT_MESSAGE_HAS(r.open, "not rectified");
}

TEST(ForeignRawlogErrors, MissingExternalImage) {
  const std::string dir = test::makeTempDir("foreign_external");
  const std::string path = dir + "/ext.rawlog";
  fs::create_directories(dir + "/ext_Images");
  const ForeignRig rig;
  std::vector<mrpt::serialization::CSerializable::Ptr> objects;
  for (int k = 0; k < 2; ++k) {
    auto s = stereoObs(rig, ticksTime(1'000'000'000LL * (k + 1)), "CAM", k);
    const std::string left = "l" + std::to_string(k) + ".png";
    const std::string right = "r" + std::to_string(k) + ".png";
    ASSERT_TRUE(cv::imwrite(dir + "/ext_Images/" + left, pattern(kWidth, kHeight, k)));
    if (k == 0) {
      ASSERT_TRUE(cv::imwrite(dir + "/ext_Images/" + right, pattern(kWidth, kHeight, k)));
    }
    s->imageLeft.setExternalStorage(left);
    s->imageRight.setExternalStorage(right);
    objects.push_back(s);
  }
  writeObservations(path, objects);
  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_EQ(r.frames.size(), 1u);
  ASSERT_FALSE(r.end.isOk());
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, path);
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, "frame 1");
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, dir + "/ext_Images/r1.png");
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, "missing");
}

// --- (c) images stored inside the log ------------------------------------------------------

// MRPT writes colour images as JPEG when asked (CImage::DISABLE_JPEG_COMPRESSION(false)).
class JpegSerialization {
 public:
  JpegSerialization() : saved_(mrpt::img::CImage::DISABLE_JPEG_COMPRESSION()) {
    mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(false);
  }
  ~JpegSerialization() { mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(saved_); }
  JpegSerialization(const JpegSerialization&) = delete;
  JpegSerialization& operator=(const JpegSerialization&) = delete;

 private:
  bool saved_;
};

/// An observations-only log of `frames` stereo pairs with smooth colour images stored inside it
/// as JPEG.
void writeJpegLog(const std::string& path, int frames) {
  const ForeignRig rig;
  const JpegSerialization jpeg;
  std::vector<mrpt::serialization::CSerializable::Ptr> objects;
  for (int k = 0; k < frames; ++k) {
    auto s = stereoObs(rig, ticksTime(1'000'000'000LL * (k + 1)), "CAM", k);
    s->imageLeft = mrpt::img::CImage(smoothColour(kWidth, kHeight, k), mrpt::img::DEEP_COPY);
    s->imageRight = mrpt::img::CImage(smoothColour(kWidth, kHeight, k + 7), mrpt::img::DEEP_COPY);
    objects.push_back(s);
  }
  writeObservations(path, objects);
}

/// Index of the n-th (from 0) occurrence of `what` in `bytes`, or npos.
size_t nthOccurrence(const std::string& bytes, const std::string& what, int n) {
  size_t at = bytes.find(what);
  for (int k = 0; k < n && at != std::string::npos; ++k) at = bytes.find(what, at + 1);
  return at;
}

const std::string kJpegStart("\xFF\xD8\xFF", 3);

// JPEG images inside the log are decoded by the reader (OpenCV), not by MRPT, and come back as
// their grey levels.
TEST(ForeignRawlog, EmbeddedJpegImages) {
  const std::string dir = test::makeTempDir("foreign_jpeg");
  const std::string path = dir + "/jpeg.rawlog";
  writeJpegLog(path, 2);
  ASSERT_NE(nthOccurrence(readBytes(path), kJpegStart, 3), std::string::npos)
      << "the log does not hold four JPEG images";
  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_TRUE(r.end.isOk()) << r.end.message();
  ASSERT_EQ(r.frames.size(), 2u);
  constexpr double kJpegGreyTol = 3.0;  // mean |error| of a quality-95 JPEG of a smooth image
  for (int k = 0; k < 2; ++k) {
    for (const auto& [img, seed] : {std::make_pair(&r.frames[k].stereo.left, k),
                                    std::make_pair(&r.frames[k].stereo.right, k + 7)}) {
      ASSERT_EQ(img->width, kWidth);
      ASSERT_EQ(img->height, kHeight);
      cv::Mat grey;
      cv::cvtColor(smoothColour(kWidth, kHeight, seed), grey, cv::COLOR_BGR2GRAY);
      double sum = 0.0;
      for (int v = 0; v < kHeight; ++v)
        for (int u = 0; u < kWidth; ++u) sum += std::abs((*img)(u, v) - grey.at<uint8_t>(v, u));
      EXPECT_LT(sum / (kWidth * kHeight), kJpegGreyTol) << "frame " << k << " seed " << seed;
    }
  }
}

// A JPEG inside the log that is corrupt: MRPT 2.5 would decode it with libjpeg's default error
// handler, which calls exit(1) ("Not a JPEG file: starts with 0x00 0x00"). It is an error of
// its frame, and the frames before it are delivered.
TEST(ForeignRawlogErrors, CorruptEmbeddedJpegIsAnErrorOfItsFrame) {
  const std::string dir = test::makeTempDir("foreign_bad_jpeg");
  for (int frame : {0, 2}) {
    const std::string path = dir + "/bad" + std::to_string(frame) + ".rawlog";
    writeJpegLog(path, 3);
    std::string bytes = readBytes(path);
    const size_t at = nthOccurrence(bytes, kJpegStart, 2 * frame);  // the frame's left image
    ASSERT_NE(at, std::string::npos);
    std::memset(bytes.data() + at, 0, 32);
    writeBytes(path, bytes);
    const ReadResult r = readAll(path);
    ASSERT_TRUE(r.open.isOk()) << r.open.message();
    EXPECT_EQ(r.frames.size(), static_cast<size_t>(frame));
    ASSERT_FALSE(r.end.isOk());
    TWOCAM_EXPECT_MESSAGE_HAS(r.end,
                              "log '" + path + "', frame " + std::to_string(frame) +
                                  ": left image: embedded image is not a JPEG");
    EXPECT_EQ(r.end.message().find('\n'), std::string::npos) << r.end.message();
  }
  // Damage after the JPEG's header: it still decodes (libjpeg fills in what is missing) or is
  // reported, never an exit.
  const std::string path = dir + "/tail.rawlog";
  writeJpegLog(path, 2);
  std::string bytes = readBytes(path);
  const size_t at = nthOccurrence(bytes, kJpegStart, 1);
  ASSERT_NE(at, std::string::npos);
  for (size_t i = at + 200; i < at + 260; ++i) bytes[i] = static_cast<char>(i * 37);
  writeBytes(path, bytes);
  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  if (!r.end.isOk()) {
    TWOCAM_EXPECT_MESSAGE_HAS(r.end, "frame 0: right image");
  }
}

// A grey image inside the log whose byte count is larger than its pixels: MRPT 2.5 reads that
// many bytes into the image's buffer, past its end. It is an error of its frame.
TEST(ForeignRawlogErrors, EmbeddedGreyImageLargerThanItsPixels) {
  const std::string dir = test::makeTempDir("foreign_grey_size");
  const std::string path = dir + "/grey.rawlog";
  const ForeignRig rig;
  writeObservations(path,
                    {stereoObs(rig, ticksTime(1'000'000'000LL), "CAM", 0),
                     stereoObs(rig, ticksTime(2'000'000'000LL), "CAM", 1)});
  std::string bytes = readBytes(path);
  // Version 9, stored inside, grey: then width, height, origin and the byte count.
  const std::string grey_image = std::string("\x91mrpt::img::CImage\x09\x00\x00", 21);
  const size_t at = nthOccurrence(bytes, grey_image, 3);  // frame 1, right image
  ASSERT_NE(at, std::string::npos);
  const uint32_t too_many = kWidth * kHeight + 64;
  std::memcpy(bytes.data() + at + grey_image.size() + 12, &too_many, 4);
  writeBytes(path, bytes);
  const ReadResult r = readAll(path);
  ASSERT_TRUE(r.open.isOk()) << r.open.message();
  EXPECT_EQ(r.frames.size(), 1u);
  ASSERT_FALSE(r.end.isOk());
  TWOCAM_EXPECT_MESSAGE_HAS(r.end, "log '" + path + "', frame 1: ");
  TWOCAM_EXPECT_MESSAGE_HAS(
      r.end,
      "embedded grey image declares " + std::to_string(too_many) + " bytes for 40x30 pixels");
}

}  // namespace
}  // namespace twocam::io
