// Hostile-user cases of the twocam program (issue 22's reliability findings): each test runs the
// built binary on crafted input and checks for a one-line error, a non-zero exit and that no
// earlier output was lost.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
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

}  // namespace
}  // namespace twocam
