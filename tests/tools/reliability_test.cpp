// Hostile-user cases of the twocam program (issue 22's reliability findings): each test runs the
// built binary on crafted input and checks for a one-line error, a non-zero exit and that no
// earlier output was lost.

#include <gtest/gtest.h>
#include <mrpt/img/CImage.h>
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/obs/CObservationOdometry.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DQuat.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <string>

#include "support/command.h"
#include "support/test_paths.h"

namespace twocam {
namespace {

namespace fs = std::filesystem;
using test::readFile;

struct RunResult {
  int exit_code = -1;
  std::string error;  // stderr
};

/// Runs twocam with a time limit, so that a hang fails the test instead of the suite.
constexpr int kTimeLimitS = 120;  // a 3-frame simulation takes ~3 s
RunResult run(const std::string& args) {
  const test::CommandResult c = test::runCommand("timeout " + std::to_string(kTimeLimitS) + " " +
                                                 std::string(TWOCAM_BINARY) + " " + args);
  return {c.exit_code, c.err};
}

std::string smallWorld() { return test::sourceDir() + "/tests/data/small_world.yaml"; }

void writeFile(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  f << text;
}

int countFiles(const std::string& dir) {
  int n = 0;
  std::error_code ec;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); ++it) ++n;
  return n;
}

/// A finished 2-frame log a.rawlog in dir, as an earlier run left it.
void simulateEarlierLog(const std::string& dir) {
  const RunResult r = run("simulate " + smallWorld() + " -o " + dir + "/a.rawlog --frames 2 -q");
  ASSERT_EQ(r.exit_code, 0) << r.error;
}

TEST(Reliability, WorldFileWithDirectiveAndInvalidUtf8IsAnErrorNotAHang) {
  const std::string dir = test::makeTempDir("reliab_hang");
  writeFile(dir + "/w.yaml", std::string("%\xff", 2));
  const RunResult r = run("simulate " + dir + "/w.yaml -o " + dir + "/w.rawlog -q");
  EXPECT_EQ(r.exit_code, 1) << "124 means the parser hung";
  EXPECT_NE(r.error.find("line 1, column 1"), std::string::npos) << r.error;
}

TEST(Reliability, SimulateRefusesToOverwriteItsWorldFile) {
  const std::string dir = test::makeTempDir("reliab_self");
  fs::copy_file(smallWorld(), dir + "/w.yaml");
  const std::string before = readFile(dir + "/w.yaml");
  const RunResult r = run("simulate " + dir + "/w.yaml -o " + dir + "/w.yaml --frames 2 -q");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.error.find("would overwrite the input"), std::string::npos) << r.error;
  EXPECT_EQ(readFile(dir + "/w.yaml"), before);
  // The world copy beside a log named after the world ("w.world.yaml") is another file, but a
  // log whose sidecar is the world is refused too.
  fs::copy_file(smallWorld(), dir + "/x.world.yaml");
  const RunResult r2 =
      run("simulate " + dir + "/x.world.yaml -o " + dir + "/x.rawlog --frames 2 -q");
  EXPECT_EQ(r2.exit_code, 1);
  EXPECT_NE(r2.error.find("would overwrite the input"), std::string::npos) << r2.error;
  EXPECT_FALSE(fs::exists(dir + "/x.rawlog"));
}

TEST(Reliability, PreviewDirThatIsAFileFailsBeforeTheLogIsReplaced) {
  const std::string dir = test::makeTempDir("reliab_preview");
  simulateEarlierLog(dir);
  const std::string log_before = readFile(dir + "/a.rawlog");
  writeFile(dir + "/P", "not a folder");
  const RunResult r = run("simulate " + smallWorld() + " -o " + dir +
                          "/a.rawlog --frames 3 -q --preview-dir " + dir + "/P");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.error.find("is a file, not a folder"), std::string::npos) << r.error;
  EXPECT_EQ(readFile(dir + "/a.rawlog"), log_before);
  EXPECT_EQ(countFiles(dir + "/a_Images"), 4);  // 2 frames x (left, right)
  EXPECT_EQ(readFile(dir + "/P"), "not a folder");
}

TEST(Reliability, LateFailureKeepsThePreviousLogAndImages) {
  const std::string dir = test::makeTempDir("reliab_late");
  simulateEarlierLog(dir);
  const std::string log_before = readFile(dir + "/a.rawlog");
  // The preview's last file cannot be written (a folder is in its way; before issue 22 this
  // failed after the new log had replaced the old one): the old log and images must stay.
  fs::remove(dir + "/a_preview/simulate.json");
  fs::create_directories(dir + "/a_preview/simulate.json");
  const RunResult r = run("simulate " + smallWorld() + " -o " + dir + "/a.rawlog --frames 3 -q");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(readFile(dir + "/a.rawlog"), log_before);
  EXPECT_EQ(countFiles(dir + "/a_Images"), 4);
  for (const auto& e : fs::directory_iterator(dir)) {
    EXPECT_EQ(e.path().string().find(".partial"), std::string::npos) << e.path();
  }
}

TEST(Reliability, WorldCopyBesideTheLogReadsTheSameFromElsewhere) {
  // A world with an image texture named relative to the world file; the log goes elsewhere.
  const std::string world_dir = test::makeTempDir("reliab_sidecar_world");
  const std::string log_dir = test::makeTempDir("reliab_sidecar_log");
  fs::create_directories(world_dir + "/textures");
  // A 2x2 grey PGM is enough for a texture.
  writeFile(world_dir + "/textures/t.pgm", std::string("P5\n2 2\n255\n\x10\x80\x80\xf0", 15));
  std::string world = readFile(smallWorld());
  const std::string from = "texture: {kind: checker, scale_m: 0.1}";
  ASSERT_NE(world.find(from), std::string::npos);
  world.replace(world.find(from),
                from.size(),
                "texture: {kind: image, file: textures/t.pgm, texels_per_m: 20}");
  writeFile(world_dir + "/w.yaml", world);
  RunResult r = run("simulate " + world_dir + "/w.yaml -o " + log_dir + "/a.rawlog --frames 2 -q");
  ASSERT_EQ(r.exit_code, 0) << r.error;
  const std::string sidecar = readFile(log_dir + "/a.world.yaml");
  EXPECT_NE(sidecar.find("'" + world_dir + "/textures/t.pgm'"), std::string::npos) << sidecar;
  // The copy simulates the same world from its own folder.
  r = run("simulate " + log_dir + "/a.world.yaml -o " + log_dir + "/b.rawlog --frames 2 -q");
  EXPECT_EQ(r.exit_code, 0) << r.error;
}

int lineCount(const std::string& text) {
  int n = 0;
  for (char c : text) n += c == '\n' ? 1 : 0;
  return n;
}

TEST(Reliability, StereoEvalUnknownPictureFormatIsOneLine) {
  const std::string dir = test::makeTempDir("reliab_stereo_eval");
  // 64 x 48 grey PGMs: random left, right = left shifted by 4 px, ground truth 4 px.
  constexpr int kW = 64, kH = 48;
  std::string left(kW * kH, '\0'), right(kW * kH, '\0');
  unsigned state = 12345;
  for (auto& c : left) {
    state = state * 1103515245u + 12345u;
    c = static_cast<char>((state >> 16) & 0xff);
  }
  for (int v = 0; v < kH; ++v)
    for (int u = 0; u < kW; ++u) right[v * kW + u] = left[v * kW + std::min(kW - 1, u + 4)];
  const std::string header = "P5\n" + std::to_string(kW) + " " + std::to_string(kH) + "\n255\n";
  writeFile(dir + "/l.pgm", header + left);
  writeFile(dir + "/r.pgm", header + right);
  writeFile(dir + "/gt.pgm", header + std::string(kW * kH, '\x04'));
  const RunResult r =
      run("stereo-eval --left " + dir + "/l.pgm --right " + dir + "/r.pgm --gt " + dir +
          "/gt.pgm --gt-scale 1 --max-disp 16 --mode dense --image " + dir + "/out.xyz");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.error.find("--image " + dir + "/out.xyz: unknown picture format '.xyz'"),
            std::string::npos)
      << r.error;
  EXPECT_EQ(lineCount(r.error), 1) << r.error;
}

TEST(Reliability, CorruptTextureImageIsOneLineWithoutLibpngNoise) {
  const std::string dir = test::makeTempDir("reliab_png");
  // A PNG whose header chunk fails its CRC: libpng printed "libpng error: IHDR: CRC error".
  std::string png("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\0\x04\0\0\0\x04\x08\0\0\0\0BAD!", 33);
  writeFile(dir + "/bad.png", png);
  std::string world = readFile(smallWorld());
  const std::string from = "texture: {kind: checker, scale_m: 0.1}";
  world.replace(world.find(from), from.size(), "texture: {kind: image, file: bad.png}");
  writeFile(dir + "/w.yaml", world);
  const RunResult r = run("simulate " + dir + "/w.yaml -o " + dir + "/w.rawlog --frames 1 -q");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.error.find("libpng"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("cannot be read as an image"), std::string::npos) << r.error;
  EXPECT_EQ(lineCount(r.error), 1) << r.error;
}

TEST(Reliability, RigAboveTheRendererLimitIsOneLine) {
  const std::string dir = test::makeTempDir("reliab_rig");
  std::string world = readFile(smallWorld());
  world.replace(world.find("width_px: 640"), 13, "width_px: 20000");
  writeFile(dir + "/w.yaml", world);
  const RunResult r = run("simulate " + dir + "/w.yaml -o " + dir + "/w.rawlog --frames 1 -q");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.error.find("rig.width_px = 20000: must be in [16, 4096]"), std::string::npos)
      << r.error;
  EXPECT_EQ(lineCount(r.error), 1) << r.error;
}

/// An observations-only log (MRPT's API, as another tool writes it) of `frames` 64 x 48 stereo
/// pairs whose colour images are stored inside the log as JPEG, with wheel odometry.
void writeJpegLog(const std::string& path, int frames) {
  const bool saved = mrpt::img::CImage::DISABLE_JPEG_COMPRESSION();
  mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(false);
  mrpt::io::CFileOutputStream f(path);
  ASSERT_TRUE(f.fileOpenCorrectly()) << path;
  auto arch = mrpt::serialization::archiveFrom(f);
  constexpr int kWidth = 64;
  constexpr int kHeight = 48;
  for (int k = 0; k < frames; ++k) {
    mrpt::obs::CObservationStereoImages obs;
    obs.sensorLabel = "CAM";
    obs.timestamp = mrpt::Clock::time_point(mrpt::Clock::duration(10'000'000LL * (k + 1)));
    obs.leftCamera.ncols = kWidth;
    obs.leftCamera.nrows = kHeight;
    obs.leftCamera.setIntrinsicParamsFromValues(60.0, 60.0, 31.5, 23.5);
    obs.rightCamera = obs.leftCamera;
    obs.cameraPose =
        mrpt::poses::CPose3DQuat(mrpt::poses::CPose3D(0.3, 0.0, 0.5, -M_PI / 2, 0.0, -M_PI / 2));
    obs.rightCameraPose = mrpt::poses::CPose3DQuat(mrpt::poses::CPose3D(0.2, 0, 0, 0, 0, 0));
    cv::Mat colour(kHeight, kWidth, CV_8UC3);
    for (int v = 0; v < kHeight; ++v)
      for (int u = 0; u < kWidth; ++u)
        colour.at<cv::Vec3b>(v, u) = cv::Vec3b(static_cast<uint8_t>(2 * u + k),
                                               static_cast<uint8_t>(3 * v),
                                               static_cast<uint8_t>(u + v));
    obs.imageLeft = mrpt::img::CImage(colour, mrpt::img::DEEP_COPY);
    obs.imageRight = mrpt::img::CImage(colour, mrpt::img::DEEP_COPY);
    obs.hasImageRight = true;
    arch << obs;
    mrpt::obs::CObservationOdometry odometry;  // else `run` warns that there is none
    odometry.sensorLabel = "ODOMETRY";
    odometry.timestamp = obs.timestamp;
    odometry.odometry = mrpt::poses::CPose2D(0.05 * k, 0.0, 0.0);
    arch << odometry;
  }
  mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(saved);
}

TEST(Reliability, CorruptJpegInsideALogIsOneLineNotLibjpegsExit) {
  const std::string dir = test::makeTempDir("reliab_jpeg");
  const std::string log = dir + "/jpeg.rawlog";
  writeJpegLog(log, 3);
  // Frame 1's left image (the third JPEG) loses its header: MRPT 2.5 handed it to libjpeg,
  // whose default error handler printed "Not a JPEG file: starts with 0x00 0x00" and called
  // exit(1).
  std::string bytes = readFile(log);
  const std::string jpeg_start("\xFF\xD8\xFF", 3);
  size_t at = bytes.find(jpeg_start);
  for (int k = 0; k < 2 && at != std::string::npos; ++k) at = bytes.find(jpeg_start, at + 1);
  ASSERT_NE(at, std::string::npos);
  std::memset(bytes.data() + at, 0, 32);
  writeFile(log, bytes);
  const RunResult r = run("run " + log + " -o " + dir + "/out -q --no-pictures");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(r.error.find("Not a JPEG file"), std::string::npos) << r.error;
  EXPECT_NE(r.error.find("log '" + log + "', frame 1: left image: embedded image is not a JPEG"),
            std::string::npos)
      << r.error;
  EXPECT_EQ(lineCount(r.error), 1) << r.error;
}

}  // namespace
}  // namespace twocam
