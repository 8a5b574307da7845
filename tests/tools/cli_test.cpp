// End-to-end tests of the twocam program: runs the built binary like a user would.

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "io/rawlog.h"
#include "support/test_paths.h"

namespace twocam {
namespace {

namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

RunResult run(const std::string& args) {
  // One output file per test and process: CTest runs the tests of this binary in parallel.
  const std::string out_file = (fs::temp_directory_path() /
                                ("twocam_cli_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
                                 std::to_string(getpid()) + ".txt"))
                                   .string();
  const std::string cmd = std::string(TWOCAM_BINARY) + " " + args + " > " + out_file + " 2>&1";
  const int rc = std::system(cmd.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  std::ifstream f(out_file);
  std::stringstream ss;
  ss << f.rdbuf();
  r.output = ss.str();
  return r;
}

std::string readFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::string smallWorld() { return test::sourceDir() + "/tests/data/small_world.yaml"; }

/// Counts frames, odometry samples and ground-truth frames in a log.
struct LogCounts {
  int frames = 0, odometry = 0, ground_truth = 0;
  Status status;
};
LogCounts countLog(const std::string& path) {
  LogCounts c;
  std::unique_ptr<io::RawlogReader> r;
  c.status = io::RawlogReader::open(path, &r);
  if (!c.status) return c;
  io::LogFrame f;
  while (r->next(&f, &c.status)) {
    ++c.frames;
    c.odometry += f.odometry ? 1 : 0;
    c.ground_truth += (f.ground_truth && !f.ground_truth->depth_left.empty()) ? 1 : 0;
  }
  return c;
}

TEST(TwocamCli, HelpListsSimulate) {
  const RunResult r = run("--help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.output.find("simulate"), std::string::npos);
  const RunResult s = run("simulate --help");
  EXPECT_EQ(s.exit_code, 0);
  EXPECT_NE(s.output.find("--frames"), std::string::npos);
  EXPECT_NE(s.output.find("--seed"), std::string::npos);
}

TEST(TwocamCli, SimulatesEveryShippedWorld) {
  const std::string dir = test::makeTempDir("cli_worlds");
  for (const char* name : {"office", "garden", "repetitive", "lowtexture"}) {
    const std::string log = dir + "/" + name + ".rawlog";
    const RunResult r = run("simulate " + test::sourceDir() + "/worlds/" + name + ".yaml -o " + log + " --frames 20 -q");
    ASSERT_EQ(r.exit_code, 0) << name << ": " << r.output;
    const LogCounts c = countLog(log);
    EXPECT_TRUE(c.status.isOk()) << name << ": " << c.status.message();
    EXPECT_EQ(c.frames, 20) << name;
    EXPECT_EQ(c.odometry, 20) << name;
    EXPECT_EQ(c.ground_truth, 20) << name;
    EXPECT_TRUE(fs::is_regular_file(dir + "/" + name + "_preview/contact_sheet.png")) << name;
  }
}

TEST(TwocamCli, SameSeedSameLogDifferentSeedDifferentLog) {
  const std::string dir = test::makeTempDir("cli_determinism");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/a.rawlog --frames 4 --seed 11 -q").exit_code, 0);
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/b.rawlog --frames 4 --seed 11 -q").exit_code, 0);
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/c.rawlog --frames 4 --seed 12 -q").exit_code, 0);
  // Byte comparisons without printing binary contents on failure.
  auto same = [&](const std::string& x, const std::string& y) { return readFile(dir + x) == readFile(dir + y); };
  EXPECT_TRUE(same("/a.rawlog", "/b.rawlog"));
  EXPECT_TRUE(same("/a_Images/left_000003.png", "/b_Images/left_000003.png"));
  EXPECT_TRUE(same("/a_Images/right_000003.png", "/b_Images/right_000003.png"));
  EXPECT_TRUE(same("/a_preview/trajectory.csv", "/b_preview/trajectory.csv"));
  EXPECT_FALSE(same("/a.rawlog", "/c.rawlog"));
  EXPECT_FALSE(same("/a_Images/left_000003.png", "/c_Images/left_000003.png"));
  EXPECT_FALSE(same("/a_preview/trajectory.csv", "/c_preview/trajectory.csv"));
}

/// Writes a copy of the small world with one line replaced (or appended) and returns its path.
std::string worldVariant(const std::string& dir, const std::string& name, const std::string& from, const std::string& to) {
  std::string text = readFile(smallWorld());
  if (from.empty()) {
    text += to + "\n";
  } else {
    const auto pos = text.find(from);
    EXPECT_NE(pos, std::string::npos) << from;
    text.replace(pos, from.size(), to);
  }
  const std::string path = dir + "/" + name + ".yaml";
  std::ofstream(path) << text;
  return path;
}

void expectRejected(const std::string& world, const std::string& dir, const std::string& message_part) {
  const std::string log = dir + "/out.rawlog";
  const RunResult r = run("simulate " + world + " -o " + log + " -q");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(message_part), std::string::npos) << "message should mention '" << message_part << "': " << r.output;
  EXPECT_FALSE(fs::exists(log)) << "no log may be left behind";
  EXPECT_FALSE(fs::exists(log + ".partial"));
}

TEST(TwocamCli, BadInputGivesClearErrorAndNoLog) {
  const std::string dir = test::makeTempDir("cli_bad");
  expectRejected(worldVariant(dir, "malformed", "shapes:", "shapes: [ {type: plane"), dir, "malformed.yaml");
  expectRejected(worldVariant(dir, "unknown", "", "colour: red"), dir, "colour");
  expectRejected(worldVariant(dir, "baseline", "baseline_m: 0.12", "baseline_m: -0.12"), dir, "baseline_m");
  expectRejected(worldVariant(dir, "texture", "{kind: blobs, scale_m: 0.05}", "{kind: image, file: no_such_texture.png, scale_m: 0.5}"), dir,
                 "no_such_texture.png");
  expectRejected(dir + "/does_not_exist.yaml", dir, "does_not_exist.yaml");
  const RunResult unwritable = run("simulate " + smallWorld() + " -o /nonexistent_twocam_dir/x.rawlog -q");
  EXPECT_NE(unwritable.exit_code, 0);
  EXPECT_NE(unwritable.output.find("/nonexistent_twocam_dir"), std::string::npos) << unwritable.output;
  const RunResult zero = run("simulate " + smallWorld() + " -o " + dir + "/z.rawlog --frames 0 -q");
  EXPECT_NE(zero.exit_code, 0);
  EXPECT_NE(zero.output.find("--frames"), std::string::npos) << zero.output;
  EXPECT_FALSE(fs::exists(dir + "/z.rawlog"));
  const RunResult missing_arg = run("simulate " + smallWorld());
  EXPECT_NE(missing_arg.exit_code, 0);
}

}  // namespace
}  // namespace twocam
