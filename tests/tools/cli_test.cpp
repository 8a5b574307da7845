// End-to-end tests of the twocam program: runs the built binary like a user would.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "io/json.h"
#include "io/rawlog.h"
#include "store/landmark_store.h"
#include "support/command.h"
#include "support/test_paths.h"

namespace twocam {
namespace {

namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout followed by stderr
  std::string error;   // stderr alone
};

using test::readFile;

RunResult run(const std::string& args) {
  const test::CommandResult c = test::runCommand(std::string(TWOCAM_BINARY) + " " + args);
  return {c.exit_code, c.out + c.err, c.err};
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
    const RunResult r = run("simulate " + test::sourceDir() + "/worlds/" + name + ".yaml -o " +
                            log + " --frames 20 -q");
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
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/a.rawlog --frames 4 --seed 11 -q")
                .exit_code,
            0);
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/b.rawlog --frames 4 --seed 11 -q")
                .exit_code,
            0);
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/c.rawlog --frames 4 --seed 12 -q")
                .exit_code,
            0);
  // Byte comparisons without printing binary contents on failure.
  auto same = [&](const std::string& x, const std::string& y) {
    return readFile(dir + x) == readFile(dir + y);
  };
  EXPECT_TRUE(same("/a.rawlog", "/b.rawlog"));
  EXPECT_TRUE(same("/a_Images/left_000003.png", "/b_Images/left_000003.png"));
  EXPECT_TRUE(same("/a_Images/right_000003.png", "/b_Images/right_000003.png"));
  EXPECT_TRUE(same("/a_preview/trajectory.csv", "/b_preview/trajectory.csv"));
  EXPECT_FALSE(same("/a.rawlog", "/c.rawlog"));
  EXPECT_FALSE(same("/a_Images/left_000003.png", "/c_Images/left_000003.png"));
  EXPECT_FALSE(same("/a_preview/trajectory.csv", "/c_preview/trajectory.csv"));
}

TEST(TwocamCli, StartWaypointZeroIsByteIdenticalAndOtherWaypointsStartElsewhere) {
  const std::string dir = test::makeTempDir("cli_start_waypoint");
  const std::string base = "simulate " + smallWorld() + " --frames 3 --seed 5 -q -o " + dir;
  ASSERT_EQ(run(base + "/none.rawlog").exit_code, 0);
  ASSERT_EQ(run(base + "/zero.rawlog --start-waypoint 0").exit_code, 0);
  ASSERT_EQ(run(base + "/two.rawlog --start-waypoint 2").exit_code, 0);
  auto same = [&](const std::string& x, const std::string& y) {
    return readFile(dir + x) == readFile(dir + y);
  };
  EXPECT_TRUE(same("/none.rawlog", "/zero.rawlog"));
  EXPECT_TRUE(same("/none_Images/left_000002.png", "/zero_Images/left_000002.png"));
  EXPECT_TRUE(same("/none_preview/trajectory.csv", "/zero_preview/trajectory.csv"));
  EXPECT_FALSE(same("/none.rawlog", "/two.rawlog"));
  // Waypoint 2 of the small world is (3, 2), heading for (0, 2): yaw pi.
  const std::string traj = readFile(dir + "/two_preview/trajectory.csv");
  EXPECT_NE(traj.find("\n0,0.000000,3.000000,2.000000,3.141593,3.000000,2.000000,3.141593\n"),
            std::string::npos)
      << traj;

  for (const char* bad : {"4", "-1"}) {
    const std::string log = dir + "/bad.rawlog";
    const RunResult r =
        run("simulate " + smallWorld() + " -o " + log + " -q --start-waypoint " + bad);
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find(std::string("--start-waypoint ") + bad), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("4 waypoints"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(log));
  }
}

/// Left image of the first frame of a log (empty when it cannot be read).
ImageU8 firstLeft(const std::string& path) {
  std::unique_ptr<io::RawlogReader> r;
  if (!io::RawlogReader::open(path, &r)) return {};
  io::LogFrame f;
  Status status;
  if (!r->next(&f, &status)) return {};
  return f.stereo.left;
}

double meanAbsDifference(const ImageU8& a, const ImageU8& b) {
  EXPECT_EQ(a.data.size(), b.data.size());
  double sum = 0.0;
  for (size_t i = 0; i < a.data.size() && i < b.data.size(); ++i)
    sum += std::abs(static_cast<int>(a.data[i]) - static_cast<int>(b.data[i]));
  return a.data.empty() ? 1e9 : sum / static_cast<double>(a.data.size());
}

TEST(TwocamCli, NoiseSeedKeepsTheTexturesAndSeedChangesThem) {
  const std::string dir = test::makeTempDir("cli_noise_seed");
  const std::string base = "simulate " + smallWorld() + " --frames 1 -q -o " + dir;
  ASSERT_EQ(run(base + "/default.rawlog").exit_code, 0);
  ASSERT_EQ(run(base + "/noise.rawlog --noise-seed 99").exit_code, 0);
  ASSERT_EQ(run(base + "/seed.rawlog --seed 99").exit_code, 0);
  const ImageU8 a = firstLeft(dir + "/default.rawlog");
  const ImageU8 n = firstLeft(dir + "/noise.rawlog");
  const ImageU8 s = firstLeft(dir + "/seed.rawlog");
  ASSERT_FALSE(a.empty());
  // Other noise only: the images differ by about the noise (sigma 2 grey, difference of two
  // draws: mean |.| ~ 2.3); other textures differ by tens of grey levels.
  constexpr double kSameTexturesGrey = 5.0;
  const double d_noise = meanAbsDifference(a, n);
  EXPECT_GT(d_noise, 0.0);
  EXPECT_LT(d_noise, kSameTexturesGrey);
  EXPECT_GT(meanAbsDifference(a, s), 2.0 * kSameTexturesGrey);
  const RunResult both = run(base + "/both.rawlog --noise-seed 3 --seed 4");
  EXPECT_NE(both.exit_code, 0);
  EXPECT_NE(both.output.find("--noise-seed"), std::string::npos) << both.output;
  EXPECT_FALSE(fs::exists(dir + "/both.rawlog"));
}

/// Writes a copy of the small world with one line replaced (or appended) and returns its path.
std::string worldVariant(const std::string& dir,
                         const std::string& name,
                         const std::string& from,
                         const std::string& to) {
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

void expectRejected(const std::string& world,
                    const std::string& dir,
                    const std::string& message_part) {
  const std::string log = dir + "/out.rawlog";
  const RunResult r = run("simulate " + world + " -o " + log + " -q");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(message_part), std::string::npos)
      << "message should mention '" << message_part << "': " << r.output;
  EXPECT_FALSE(fs::exists(log)) << "no log may be left behind";
  EXPECT_FALSE(fs::exists(log + ".partial"));
}

TEST(TwocamCli, BadInputGivesClearErrorAndNoLog) {
  const std::string dir = test::makeTempDir("cli_bad");
  expectRejected(
      worldVariant(dir, "malformed", "shapes:", "shapes: [ {type: plane"), dir, "malformed.yaml");
  expectRejected(worldVariant(dir, "unknown", "", "colour: red"), dir, "colour");
  expectRejected(
      worldVariant(dir, "baseline", "baseline_m: 0.12", "baseline_m: -0.12"), dir, "baseline_m");
  expectRejected(worldVariant(dir,
                              "texture",
                              "{kind: blobs, scale_m: 0.05}",
                              "{kind: image, file: no_such_texture.png, scale_m: 0.5}"),
                 dir,
                 "no_such_texture.png");
  expectRejected(dir + "/does_not_exist.yaml", dir, "does_not_exist.yaml");
  const RunResult unwritable =
      run("simulate " + smallWorld() + " -o /nonexistent_twocam_dir/x.rawlog -q");
  EXPECT_NE(unwritable.exit_code, 0);
  EXPECT_NE(unwritable.output.find("/nonexistent_twocam_dir"), std::string::npos)
      << unwritable.output;
  const RunResult zero = run("simulate " + smallWorld() + " -o " + dir + "/z.rawlog --frames 0 -q");
  EXPECT_NE(zero.exit_code, 0);
  EXPECT_NE(zero.output.find("--frames"), std::string::npos) << zero.output;
  EXPECT_FALSE(fs::exists(dir + "/z.rawlog"));
  const RunResult negative_noise =
      run("simulate " + smallWorld() + " -o " + dir + "/n.rawlog --odometry-noise-scale -1 -q");
  EXPECT_NE(negative_noise.exit_code, 0);
  EXPECT_NE(negative_noise.output.find("--odometry-noise-scale"), std::string::npos)
      << negative_noise.output;
  EXPECT_FALSE(fs::exists(dir + "/n.rawlog"));
  const RunResult missing_arg = run("simulate " + smallWorld());
  EXPECT_NE(missing_arg.exit_code, 0);
}

// ---- run ------------------------------------------------------------------------------------

/// Copies a log frame by frame, letting `edit` change each frame (or drop its odometry).
Status rewriteLog(const std::string& in,
                  const std::string& out,
                  const std::function<void(io::LogFrame*)>& edit) {
  std::unique_ptr<io::RawlogReader> reader;
  if (Status s = io::RawlogReader::open(in, &reader); !s) return s;
  std::unique_ptr<io::RawlogWriter> writer;
  if (Status s = io::RawlogWriter::open(out, reader->rig(), io::RawlogWriterOptions(), &writer);
      !s) {
    return s;
  }
  io::LogFrame f;
  Status status;
  while (reader->next(&f, &status)) {
    edit(&f);
    const OdometrySample* odo = f.odometry ? &*f.odometry : nullptr;
    const GroundTruthFrame* gt = f.ground_truth ? &*f.ground_truth : nullptr;
    if (Status s = writer->write(f.stereo, odo, gt); !s) return s;
  }
  if (!status) return status;
  return writer->finish();
}

TEST(TwocamCli, RunSkipsBadOdometryFramesAndRunsTheFrontendOnlyWithoutOdometry) {
  const std::string dir = test::makeTempDir("cli_run_bad_input");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/ok.rawlog --frames 8 --seed 3 -q")
                .exit_code,
            0);
  // Frame 2: NaN odometry. Frame 5: time stamp before frame 4's.
  int64_t t4 = 0;
  ASSERT_TRUE(rewriteLog(dir + "/ok.rawlog", dir + "/bad.rawlog", [&](io::LogFrame* f) {
                if (f->index == 2 && f->odometry) {
                  f->odometry->pose.x_m = std::numeric_limits<double>::quiet_NaN();
                }
                if (f->index == 4) t4 = f->stereo.t_ns;
                if (f->index == 5) {
                  f->stereo.t_ns = t4 - 1000;
                  if (f->odometry) f->odometry->t_ns = f->stereo.t_ns;
                  if (f->ground_truth) f->ground_truth->t_ns = f->stereo.t_ns;
                }
              }).isOk());
  const RunResult bad = run("run " + dir + "/bad.rawlog -o " + dir + "/out_bad -q --no-pictures");
  EXPECT_EQ(bad.exit_code, 0) << bad.output;
  size_t warnings = 0;
  for (size_t at = bad.error.find("warning: skipping"); at != std::string::npos;
       at = bad.error.find("warning: skipping", at + 1)) {
    ++warnings;
  }
  EXPECT_EQ(warnings, 2u) << bad.error;
  EXPECT_TRUE(fs::exists(dir + "/out_bad/metrics.json"));
  EXPECT_TRUE(fs::exists(dir + "/out_bad/landmarks.csv"));

  ASSERT_TRUE(rewriteLog(dir + "/ok.rawlog", dir + "/no_odo.rawlog", [](io::LogFrame* f) {
                f->odometry.reset();
              }).isOk());
  // Odometry far beyond the map's extent (+-1.6 km at 5 cm): landmarks go on, the frame is not
  // mapped, the run warns and completes.
  ASSERT_TRUE(rewriteLog(dir + "/ok.rawlog", dir + "/far.rawlog", [](io::LogFrame* f) {
                if (f->odometry) f->odometry->pose.x_m += 5000.0;
              }).isOk());
  const RunResult far = run("run " + dir + "/far.rawlog -o " + dir + "/out_far -q --no-pictures");
  EXPECT_EQ(far.exit_code, 0) << far.output;
  EXPECT_NE(far.error.find("outside the map"), std::string::npos) << far.error;
  EXPECT_NE(readFile(dir + "/out_far/metrics.json").find("\"frames_outside_map\": 8"),
            std::string::npos);

  // A log without odometry (EuRoC): the frontend runs, no landmarks, no map, and it says so.
  const RunResult no_odo =
      run("run " + dir + "/no_odo.rawlog -o " + dir + "/out_no_odo -q --no-pictures");
  EXPECT_EQ(no_odo.exit_code, 0) << no_odo.error;
  EXPECT_NE(no_odo.error.find("has no odometry"), std::string::npos) << no_odo.error;
  const std::string no_odo_json = readFile(dir + "/out_no_odo/metrics.json");
  EXPECT_NE(no_odo_json.find("\"odometry\": false"), std::string::npos) << no_odo_json;
  EXPECT_NE(no_odo_json.find("\"confirmed\": 0"), std::string::npos) << no_odo_json;
  EXPECT_FALSE(fs::exists(dir + "/out_no_odo/map.bt"));
  EXPECT_TRUE(fs::exists(dir + "/out_no_odo/sample_frame/hypotheses.csv"));

  const RunResult missing =
      run("run " + dir + "/nope.rawlog -o " + dir + "/out_missing -q --no-pictures");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.error.find("nope.rawlog"), std::string::npos) << missing.error;
  const RunResult policy =
      run("run " + dir + "/ok.rawlog -o " + dir + "/out_p --policy best -q --no-pictures");
  EXPECT_NE(policy.exit_code, 0);
  EXPECT_NE(policy.error.find("best"), std::string::npos) << policy.error;
}

TEST(TwocamCli, RunWritesEveryOutputDeterministicallyAndKeepsThemOnBadInput) {
  const std::string dir = test::makeTempDir("cli_run_outputs");
  const RunResult sim =
      run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 24 --seed 5 -q");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  ASSERT_TRUE(fs::exists(dir + "/s.world.yaml"));
  const RunResult a = run("run " + dir + "/s.rawlog -o " + dir + "/a -q --no-pictures");
  ASSERT_EQ(a.exit_code, 0) << a.output;
  for (const char* f : {"metrics.json",
                        "landmarks.csv",
                        "duplicates.csv",
                        "trajectory_odom.tum",
                        "trajectory_gt.tum",
                        "map.bt",
                        "config_used.yaml",
                        "timings.csv",
                        "timing.json",
                        "map_voxels.csv",
                        "map_eval_voxels.csv",
                        "world_outline.csv",
                        "sample_frame/left.png",
                        "sample_frame/right.png",
                        "sample_frame/hypotheses.csv"}) {
    EXPECT_TRUE(fs::exists(dir + "/a/" + f)) << f;
  }
  const std::string metrics = readFile(dir + "/a/metrics.json");
  for (const char* key : {"\"octomap\"",
                          "\"phantom_fraction\"",
                          "\"ate_rmse_m\"",
                          "\"precision\"",
                          "\"by_texture\"",
                          "\"seed\": 1",
                          "\"odometry\": true"}) {
    EXPECT_NE(metrics.find(key), std::string::npos) << key << "\n" << metrics;
  }
  // TUM: one pose per processed frame after the comment lines.
  std::istringstream tum(readFile(dir + "/a/trajectory_odom.tum"));
  int poses = 0;
  for (std::string line; std::getline(tum, line);) poses += !line.empty() && line[0] != '#';
  EXPECT_EQ(poses, 24);

  // Same log, same config: identical metrics.json, landmarks.csv and map; the recorded config
  // reproduces the run.
  const RunResult b = run("run " + dir + "/s.rawlog -o " + dir + "/b -q --no-pictures --config " +
                          dir + "/a/config_used.yaml");
  ASSERT_EQ(b.exit_code, 0) << b.output;
  EXPECT_EQ(readFile(dir + "/a/metrics.json"), readFile(dir + "/b/metrics.json"));
  EXPECT_EQ(readFile(dir + "/a/landmarks.csv"), readFile(dir + "/b/landmarks.csv"));
  EXPECT_EQ(readFile(dir + "/a/duplicates.csv"), readFile(dir + "/b/duplicates.csv"));
  EXPECT_EQ(readFile(dir + "/a/duplicates.csv")
                .rfind("frame,id,first_frame,older_id,older_first_frame,older_confirmed_frame,"
                       "older_last_seen_frame\n",
                       0),
            0u);
  EXPECT_EQ(readFile(dir + "/a/map.bt"), readFile(dir + "/b/map.bt"));

  // A config changes the run: a coarser map has fewer voxels; --policy overrides the file.
  {
    std::ofstream cfg(dir + "/coarse.yaml");
    cfg << "mapping:\n  resolution_m: 0.2\nlandmarks:\n  policy: seen-count\n";
  }
  const RunResult c = run("run " + dir + "/s.rawlog -o " + dir + "/c -q --no-pictures --config " +
                          dir + "/coarse.yaml --policy wta-lrc");
  ASSERT_EQ(c.exit_code, 0) << c.output;
  EXPECT_NE(readFile(dir + "/c/metrics.json").find("\"resolution_m\": 0.2"), std::string::npos);
  EXPECT_NE(readFile(dir + "/c/metrics.json").find("\"policy\": \"wta-lrc\""), std::string::npos);
  EXPECT_NE(readFile(dir + "/c/config_used.yaml").find("resolution_m: 0.2"), std::string::npos);

  // Bad input: clear error, exit 1, and the earlier results in the folder are untouched.
  const std::string before = readFile(dir + "/a/metrics.json");
  const std::string before_map = readFile(dir + "/a/map.bt");
  {
    std::ofstream cfg(dir + "/typo.yaml");
    cfg << "mapping:\n  resolutoin_m: 0.1\n";
  }
  const RunResult typo = run("run " + dir + "/s.rawlog -o " + dir +
                             "/a -q --no-pictures --config " + dir + "/typo.yaml");
  EXPECT_EQ(typo.exit_code, 1);
  EXPECT_NE(typo.error.find("resolutoin_m"), std::string::npos) << typo.error;
  // Truncated log: the first half of the gzip stream.
  {
    const std::string full = readFile(dir + "/s.rawlog");
    std::ofstream cut(dir + "/cut.rawlog", std::ios::binary);
    cut << full.substr(0, full.size() / 2);
  }
  fs::copy(dir + "/s_Images", dir + "/cut_Images", fs::copy_options::recursive);
  const RunResult cut = run("run " + dir + "/cut.rawlog -o " + dir + "/a -q --no-pictures");
  EXPECT_EQ(cut.exit_code, 1) << cut.output;
  EXPECT_NE(cut.error.find("cut.rawlog"), std::string::npos) << cut.error;
  // Corrupt log: random bytes.
  {
    std::ofstream junk(dir + "/junk.rawlog", std::ios::binary);
    std::mt19937 rng(11);
    for (int i = 0; i < 4096; ++i) junk.put(static_cast<char>(rng() & 0xff));
  }
  const RunResult junk = run("run " + dir + "/junk.rawlog -o " + dir + "/a -q --no-pictures");
  EXPECT_EQ(junk.exit_code, 1) << junk.output;
  EXPECT_NE(junk.error.find("junk.rawlog"), std::string::npos) << junk.error;
  // Output "folder" that is a file.
  {
    std::ofstream f(dir + "/plainfile");
    f << "x";
  }
  const RunResult unwritable =
      run("run " + dir + "/s.rawlog -o " + dir + "/plainfile -q --no-pictures");
  EXPECT_EQ(unwritable.exit_code, 1);
  EXPECT_NE(unwritable.error.find("plainfile"), std::string::npos) << unwritable.error;
  EXPECT_EQ(readFile(dir + "/plainfile"), "x");
  EXPECT_EQ(readFile(dir + "/a/metrics.json"), before);
  EXPECT_EQ(readFile(dir + "/a/map.bt"), before_map);
  EXPECT_FALSE(fs::exists(dir + "/a/metrics.json.partial"));
}

/// Every file below `dir` with its bytes (folders as "<dir>"), to check "untouched byte for byte".
std::map<std::string, std::string> snapshot(const std::string& dir) {
  std::map<std::string, std::string> t;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    t[fs::relative(e.path(), dir).string()] =
        e.is_directory() ? "<dir>" : readFile(e.path().string());
  }
  return t;
}

/// Staging folders (".<name>.staging-XXXXXX") left in `dir`.
int stagingLeftovers(const std::string& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    n += e.path().filename().string().find(".staging-") != std::string::npos;
  return n;
}

TEST(TwocamCli, RunLocalizesInEachModeAndRefusesAnUnknownOne) {
  const std::string dir = test::makeTempDir("cli_run_localization");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 30 --seed 3 -q")
                .exit_code,
            0);
  for (const std::string& mode : {std::string("fused"), std::string("pnp")}) {
    const RunResult r = run("run " + dir + "/s.rawlog -o " + dir + "/" + mode +
                            " -q --no-pictures --localization " + mode);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    std::istringstream tum(readFile(dir + "/" + mode + "/trajectory_est.tum"));
    int poses = 0;
    for (std::string line; std::getline(tum, line);) poses += !line.empty() && line[0] != '#';
    EXPECT_EQ(poses, 30) << mode;
    const std::string metrics = readFile(dir + "/" + mode + "/metrics.json");
    for (const std::string& key : {"\"" + mode + "\": ",  // its ATE and final error
                                   "\"mode\": \"" + mode + "\"",
                                   std::string("\"visual_fraction\""),
                                   std::string("\"slips\""),
                                   std::string("\"localization_median\"")}) {
      EXPECT_NE((metrics + readFile(dir + "/" + mode + "/timing.json")).find(key),
                std::string::npos)
          << mode << ": " << key << "\n"
          << metrics;
    }
    EXPECT_NE(readFile(dir + "/" + mode + "/config_used.yaml").find("mode: " + mode),
              std::string::npos);
  }
  // Same log, same mode: the same output.
  const RunResult again =
      run("run " + dir + "/s.rawlog -o " + dir + "/again -q --no-pictures --localization fused");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(readFile(dir + "/fused/metrics.json"), readFile(dir + "/again/metrics.json"));
  EXPECT_EQ(readFile(dir + "/fused/trajectory_est.tum"),
            readFile(dir + "/again/trajectory_est.tum"));
  // The default is fused.
  const RunResult def = run("run " + dir + "/s.rawlog -o " + dir + "/default -q --no-pictures");
  ASSERT_EQ(def.exit_code, 0) << def.output;
  EXPECT_EQ(readFile(dir + "/fused/trajectory_est.tum"),
            readFile(dir + "/default/trajectory_est.tum"));
  // The localisation and map metrics of METRICS.md are there.
  const std::string fused_metrics = readFile(dir + "/fused/metrics.json");
  for (const char* key : {"\"rpe_trans_pct\"",
                          "\"rpe_rot_deg_per_m\"",
                          "\"completeness\"",
                          "\"oracle_poses\"",
                          "\"odometry_frame\"",
                          "\"map_error_median_m\"",
                          "\"duplicate_fraction\""}) {
    EXPECT_NE(fused_metrics.find(key), std::string::npos) << key;
  }
  // localization.csv: per frame the inliers (landmarks_used) of the observations the pose was
  // solved on (landmarks_observed, the last column); the frames with a visual pose had some.
  {
    std::istringstream csv(readFile(dir + "/fused/localization.csv"));
    std::string line;
    ASSERT_TRUE(std::getline(csv, line));
    ASSERT_GE(line.size(), std::string(",landmarks_observed").size()) << line;
    EXPECT_EQ(line.substr(line.rfind(',')), ",landmarks_observed") << line;
    int rows = 0, visual_rows = 0;
    while (std::getline(csv, line)) {
      std::vector<std::string> cells;
      std::istringstream cs(line);
      for (std::string c; std::getline(cs, c, ',');) cells.push_back(c);
      ASSERT_EQ(cells.size(), 22u) << line;
      const int used = std::stoi(cells[3]);
      const int observed = std::stoi(cells[21]);
      EXPECT_LE(used, observed) << line;
      if (cells[2] == "1") {
        ++visual_rows;
        EXPECT_GT(observed, 0) << line;
      }
      ++rows;
    }
    EXPECT_EQ(rows, 30);
    EXPECT_GT(visual_rows, 0);
  }
  // Odometry mode writes no estimated track.
  const RunResult odo =
      run("run " + dir + "/s.rawlog -o " + dir + "/odo -q --no-pictures --localization odometry");
  ASSERT_EQ(odo.exit_code, 0) << odo.output;
  EXPECT_FALSE(fs::exists(dir + "/odo/trajectory_est.tum"));
  EXPECT_NE(readFile(dir + "/odo/config_used.yaml").find("mode: odometry"), std::string::npos);
  // An unknown mode: an error naming what was typed, exit 1, no output folder.
  const RunResult bad =
      run("run " + dir + "/s.rawlog -o " + dir + "/bad -q --no-pictures --localization kalman");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.error.find("--localization kalman"), std::string::npos) << bad.error;
  EXPECT_NE(bad.error.find("odometry, pnp or fused"), std::string::npos) << bad.error;
  EXPECT_FALSE(fs::exists(dir + "/bad"));
}

TEST(TwocamCli, RunRecordsItsMapAndRefusesToOverwriteOne) {
  const std::string dir = test::makeTempDir("cli_run_map");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 30 --seed 3 -q")
                .exit_code,
            0);
  const std::string map = dir + "/m.db";
  const RunResult r =
      run("run " + dir + "/s.rawlog -o " + dir + "/out -q --no-pictures --map " + map);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const io::Json metrics = io::Json::parse(readFile(dir + "/out/metrics.json"));
  const int64_t confirmed = metrics["landmarks"]["confirmed"].get<int64_t>();
  ASSERT_GT(confirmed, 0);
  EXPECT_NE(r.output.find("map: " + std::to_string(confirmed) + " landmarks and 30 poses"),
            std::string::npos)
      << r.output;
  // The map holds the run's confirmed landmarks and one pose per frame.
  const RunResult info = run("map info " + map);
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("landmarks: " + std::to_string(confirmed)), std::string::npos)
      << info.output;
  EXPECT_NE(info.output.find("keyframes: 30"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("s.rawlog"), std::string::npos) << info.output;
  const std::string before = readFile(map);
  // Localising in the map (read only): the same log is placed at once, within the map's own
  // error, and its poses are given in the map frame.
  const RunResult loc = run("run " + dir + "/s.rawlog -o " + dir + "/loc -q --no-pictures --map " +
                            map + " --localize-only");
  ASSERT_EQ(loc.exit_code, 0) << loc.output;
  EXPECT_EQ(readFile(map), before);
  const io::Json reloc = io::Json::parse(readFile(dir + "/loc/metrics.json"))["relocalization"];
  EXPECT_EQ(reloc["frame"].get<int>(), 0) << reloc.dump();
  constexpr double kMaxRelocErrorM = 0.05;
  ASSERT_TRUE(reloc["error_m"].is_number()) << reloc.dump();
  EXPECT_LT(reloc["error_m"].get<double>(), kMaxRelocErrorM);
  EXPECT_TRUE(fs::exists(dir + "/loc/trajectory_map.tum"));
  // The map's landmarks joined the run's tracker after placement.
  EXPECT_GT(reloc["restored_landmarks"].get<int64_t>(), 0) << reloc.dump();
  // The map's opening and the placement are timed: placed after it was opened and read.
  ASSERT_TRUE(reloc["open_ms"].is_number() && reloc["placed_ms"].is_number()) << reloc.dump();
  EXPECT_GT(reloc["open_ms"].get<double>(), 0.0);
  EXPECT_GT(reloc["placed_ms"].get<double>(), reloc["open_ms"].get<double>());
  EXPECT_NE(loc.output.find("relocalisation: frame 0 placed"), std::string::npos) << loc.output;
  const RunResult no_map =
      run("run " + dir + "/s.rawlog -o " + dir + "/nomap -q --no-pictures --localize-only");
  EXPECT_EQ(no_map.exit_code, 1);
  EXPECT_NE(no_map.error.find("--localize-only needs --map"), std::string::npos) << no_map.error;
  // A file that is not a store: refused, unchanged.
  { std::ofstream(dir + "/notes.txt") << "not a map\n"; }
  const RunResult bad = run("run " + dir + "/s.rawlog -o " + dir + "/out3 -q --no-pictures --map " +
                            dir + "/notes.txt");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.error.find("notes.txt"), std::string::npos) << bad.error;
  EXPECT_EQ(readFile(dir + "/notes.txt"), "not a map\n");
  EXPECT_FALSE(fs::exists(dir + "/out3"));
}

TEST(TwocamCli, RunReportsEachMapCommitAndMapCheckRunsTheIntegrityCheck) {
  const std::string dir = test::makeTempDir("cli_run_map_commits");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 25 --seed 3 -q")
                .exit_code,
            0);
  const std::string map = dir + "/m.db";
  const RunResult r = run("run " + dir + "/s.rawlog -o " + dir + "/out -q --no-pictures --map " +
                          map + " --map-commit-log " + dir + "/commits.txt");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // One line per transaction of 10 frames (MapRecorderOptions::frames_per_commit), the last one
  // the end of the run; each names the last frame it committed.
  EXPECT_EQ(readFile(dir + "/commits.txt"),
            "session 1 frame 9 keyframes 10\n"
            "session 1 frame 19 keyframes 20\n"
            "session 1 frame 24 keyframes 25\n");
  const RunResult check = run("map check " + map);
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find(map + ": integrity check ok"), std::string::npos) << check.output;

  // Extending the map: the commits are the new session's, from the placed frame on.
  const RunResult second = run("run " + dir + "/s.rawlog -o " + dir + "/out2 -q --no-pictures " +
                               "--map " + map + " --map-commit-log " + dir + "/commits.txt");
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_EQ(readFile(dir + "/commits.txt").rfind("session 2 frame ", 0), 0u)
      << readFile(dir + "/commits.txt");
  EXPECT_NE(readFile(dir + "/commits.txt").find("session 2 frame 24 keyframes "),
            std::string::npos);

  // Misuse: a clear error, nothing run.
  const RunResult no_map = run("run " + dir + "/s.rawlog -o " + dir + "/out3 -q --no-pictures " +
                               "--map-commit-log " + dir + "/c3.txt");
  EXPECT_EQ(no_map.exit_code, 1);
  EXPECT_NE(no_map.error.find("--map-commit-log needs --map"), std::string::npos) << no_map.error;
  const RunResult loc = run("run " + dir + "/s.rawlog -o " + dir + "/out4 -q --no-pictures --map " +
                            map + " --localize-only --map-commit-log " + dir + "/c4.txt");
  EXPECT_EQ(loc.exit_code, 1);
  EXPECT_NE(loc.error.find("without --localize-only"), std::string::npos) << loc.error;
  const RunResult unwritable =
      run("run " + dir + "/s.rawlog -o " + dir + "/out5 -q " + "--no-pictures --map " + map +
          " --map-commit-log " + dir + "/absent/c5.txt");
  EXPECT_EQ(unwritable.exit_code, 1);
  EXPECT_NE(unwritable.error.find(dir + "/absent/c5.txt"), std::string::npos) << unwritable.error;
  EXPECT_FALSE(fs::exists(dir + "/c3.txt"));
  EXPECT_FALSE(fs::exists(dir + "/c4.txt"));

  // map check on a damaged map (pages 3..6 overwritten) or on another file: exit 1 naming it,
  // the file unchanged.
  constexpr size_t kPageBytes = 4096;  // SQLite's default page size
  std::string bytes = readFile(map);
  ASSERT_GT(bytes.size(), 8 * kPageBytes);
  std::mt19937 rng(5);
  for (size_t i = 2 * kPageBytes; i < 6 * kPageBytes; ++i) bytes[i] = static_cast<char>(rng());
  const std::string damaged = dir + "/damaged.db";
  { std::ofstream(damaged, std::ios::binary) << bytes; }
  const RunResult bad = run("map check " + damaged);
  EXPECT_EQ(bad.exit_code, 1) << bad.output;
  EXPECT_NE(bad.error.find("twocam map check: error: "), std::string::npos) << bad.error;
  EXPECT_NE(bad.error.find(damaged), std::string::npos) << bad.error;
  EXPECT_EQ(readFile(damaged), bytes);
  { std::ofstream(dir + "/notes.txt") << "not a map\n"; }
  const RunResult notes = run("map check " + dir + "/notes.txt");
  EXPECT_EQ(notes.exit_code, 1);
  EXPECT_NE(notes.error.find("notes.txt"), std::string::npos) << notes.error;
  EXPECT_EQ(readFile(dir + "/notes.txt"), "not a map\n");
}

/// Every landmark of a map by id.
std::map<uint64_t, store::StoredLandmark> loadMap(const std::string& path) {
  std::unique_ptr<store::LandmarkStore> st;
  std::vector<store::StoredLandmark> all;
  std::map<uint64_t, store::StoredLandmark> by_id;
  if (!store::LandmarkStore::open(path, store::OpenMode::kReadOnly, &st) || !st->loadAll(&all))
    return by_id;
  for (store::StoredLandmark& l : all) by_id[l.id] = std::move(l);
  return by_id;
}

TEST(TwocamCli, RunExtendsAMapWithASecondSessionOnlyOncePlacedInIt) {
  const std::string dir = test::makeTempDir("cli_run_map_extend");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 30 -q").exit_code,
            0);
  const std::string map = dir + "/m.db";
  ASSERT_EQ(
      run("run " + dir + "/s.rawlog -o " + dir + "/out -q --no-pictures --map " + map).exit_code,
      0);
  const std::map<uint64_t, store::StoredLandmark> first = loadMap(map);
  ASSERT_FALSE(first.empty());
  std::unique_ptr<store::LandmarkStore> st;
  store::StoreInfo info1;
  ASSERT_TRUE(store::LandmarkStore::open(map, store::OpenMode::kReadOnly, &st));
  ASSERT_TRUE(st->info(&info1));
  st.reset();

  // A log of another world is never placed in the map: exit 2 saying so, the map byte for byte
  // as it was (no session, nothing in a write-ahead log: a read-only open may leave an empty
  // one), the run's own outputs written.
  ASSERT_EQ(run("simulate " + test::sourceDir() + "/worlds/lowtexture.yaml -o " + dir +
                "/other.rawlog --frames 12 -q")
                .exit_code,
            0);
  const std::string before = readFile(map);
  const RunResult other =
      run("run " + dir + "/other.rawlog -o " + dir + "/other -q --no-pictures --map " + map);
  EXPECT_EQ(other.exit_code, 2) << other.output;
  EXPECT_NE(other.error.find("never placed in the map " + map), std::string::npos) << other.error;
  EXPECT_NE(other.error.find("not merged"), std::string::npos) << other.error;
  EXPECT_EQ(readFile(map), before);
  EXPECT_TRUE(!fs::exists(map + "-wal") || fs::file_size(map + "-wal") == 0);
  const io::Json never = io::Json::parse(readFile(dir + "/other/metrics.json"))["relocalization"];
  EXPECT_EQ(never["frame"].get<int>(), -1) << never.dump();

  // The same world again (another noise seed): placed, then recorded as session 2.
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir +
                "/s2.rawlog --frames 30 "
                "--noise-seed 11 -q")
                .exit_code,
            0);
  const RunResult second =
      run("run " + dir + "/s2.rawlog -o " + dir + "/out2 -q --no-pictures --map " + map);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  const io::Json reloc = io::Json::parse(readFile(dir + "/out2/metrics.json"))["relocalization"];
  ASSERT_GE(reloc["frame"].get<int>(), 0) << reloc.dump();
  const int placed = reloc["frame"].get<int>();
  EXPECT_NE(second.output.find("map: session 2 added"), std::string::npos) << second.output;
  const RunResult info = run("map info " + map);
  ASSERT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("sessions: 2"), std::string::npos) << info.output;
  EXPECT_NE(info.output.find("s2.rawlog, " + std::to_string(30 - placed) + " keyframes"),
            std::string::npos)
      << info.output;

  const std::map<uint64_t, store::StoredLandmark> both = loadMap(map);
  int seen_again = 0;
  for (const auto& [id, l1] : first) {
    // Session 1's landmarks are all still there, under their ids, where they were.
    const auto it = both.find(id);
    ASSERT_NE(it, both.end()) << id;
    const store::StoredLandmark& l = it->second;
    EXPECT_EQ(l.session, 1);
    EXPECT_EQ(l.p_m, l1.p_m) << id;
    EXPECT_GE(l.observations, l1.observations) << id;
    if (l.observations > l1.observations) {
      ++seen_again;
      EXPECT_GT(l.last_seen_t_ns, 0);
    }
  }
  // Session 2 saw the map's landmarks again and updated them instead of inserting them again.
  EXPECT_GT(seen_again, static_cast<int>(first.size()) / 4) << seen_again << " of " << first.size();
  int inserted = 0;
  for (const auto& [id, l] : both) {
    if (first.count(id) > 0) continue;
    ++inserted;
    EXPECT_EQ(l.session, 2) << id;
    EXPECT_GE(id, info1.next_landmark_id) << id;  // the numbering continues
  }
  EXPECT_LT(inserted, static_cast<int>(first.size()) / 2) << inserted << " new of " << first.size();
  // Session 2's poses are in the map frame: its first keyframe near the first session's pose of
  // the same frame (the same path).
  ASSERT_TRUE(store::LandmarkStore::open(map, store::OpenMode::kReadOnly, &st));
  std::vector<store::StoredKeyframe> k1, k2;
  ASSERT_TRUE(st->keyframes(1, &k1));
  ASSERT_TRUE(st->keyframes(2, &k2));
  ASSERT_EQ(k2.size(), static_cast<size_t>(30 - placed));
  EXPECT_EQ(k2.front().frame, placed);
  constexpr double kMaxMapFrameOffsetM = 0.05;
  EXPECT_LT((k2.front().T_m_b.translation() - k1[placed].T_m_b.translation()).norm(),
            kMaxMapFrameOffsetM);
}

TEST(TwocamCli, RunReplacesAnEarlierRunAllOrNothingAndNeverAnInput) {
  const std::string dir = test::makeTempDir("cli_run_all_or_nothing");
  ASSERT_EQ(
      run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 8 --seed 5 -q").exit_code,
      0);
  ASSERT_EQ(run("run " + dir + "/s.rawlog -o " + dir + "/a -q --no-pictures").exit_code, 0);
  const auto before = snapshot(dir + "/a");
  ASSERT_TRUE(before.count("sample_frame/left.png"));

  // A late write fails (the sample frame, written after 8 other files before this change):
  // exit 1, and the earlier run's folder is untouched byte for byte.
  for (const char* late : {"sample_frame/left.png", "metrics.json", "map_eval_voxels.csv"}) {
    const test::CommandResult r =
        test::runCommand(std::string("TWOCAM_TEST_FAIL_WRITE=") + late + " " + TWOCAM_BINARY +
                         " run " + dir + "/s.rawlog -o " + dir +
                         "/a -q --no-pictures --policy "
                         "wta-lrc");
    EXPECT_EQ(r.exit_code, 1) << late << "\n" << r.err;
    EXPECT_NE(r.err.find(late), std::string::npos) << r.err;
    EXPECT_EQ(snapshot(dir + "/a"), before) << late;
    EXPECT_EQ(stagingLeftovers(dir), 0) << late;
  }
  // A read-only sample_frame/ in the earlier folder does not matter: the new run is staged
  // elsewhere and replaces the folder as a whole.
  fs::permissions(dir + "/a/sample_frame", fs::perms::owner_read | fs::perms::owner_exec);
  const RunResult again =
      run("run " + dir + "/s.rawlog -o " + dir + "/a -q --no-pictures --policy wta-lrc");
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(readFile(dir + "/a/metrics.json").find("\"policy\": \"wta-lrc\""), std::string::npos);
  EXPECT_TRUE(fs::exists(dir + "/a/sample_frame/left.png"));
  EXPECT_EQ(stagingLeftovers(dir), 0);

  // An output that is an input, holds one or lies in one: an error before any work.
  {
    std::ofstream cfg(dir + "/cfg.yaml");
    cfg << "mapping:\n  resolution_m: 0.1\n";
  }
  const auto inputs = snapshot(dir + "/s_Images");
  const std::string log_bytes = readFile(dir + "/s.rawlog");
  const std::string world_bytes = readFile(dir + "/s.world.yaml");
  for (const std::string& out : {dir + "/s.rawlog",
                                 dir + "/s_Images",
                                 dir + "/s_Images/out",
                                 dir + "/s.world.yaml",
                                 dir + "/cfg.yaml",
                                 dir,
                                 dir + "/s.rawlog/sub"}) {
    const RunResult r = run("run " + dir + "/s.rawlog -o " + out + " --config " + dir +
                            "/cfg.yaml -q --no-pictures");
    EXPECT_EQ(r.exit_code, 1) << out << "\n" << r.output;
    EXPECT_NE(r.error.find(out), std::string::npos) << r.error;
    EXPECT_EQ(r.output.find("frames:"), std::string::npos) << "work was done for " << out;
  }
  EXPECT_EQ(snapshot(dir + "/s_Images"), inputs);
  EXPECT_EQ(readFile(dir + "/s.rawlog"), log_bytes);
  EXPECT_EQ(readFile(dir + "/s.world.yaml"), world_bytes);
  // A folder that is not an earlier run's (no metrics.json) is not replaced.
  fs::create_directories(dir + "/mine");
  { std::ofstream(dir + "/mine/notes.txt") << "keep"; }
  const RunResult mine = run("run " + dir + "/s.rawlog -o " + dir + "/mine -q --no-pictures");
  EXPECT_EQ(mine.exit_code, 1) << mine.output;
  EXPECT_NE(mine.error.find("metrics.json"), std::string::npos) << mine.error;
  EXPECT_EQ(readFile(dir + "/mine/notes.txt"), "keep");
}

TEST(TwocamCli, RunSaysWhyThereIsNoMapEvaluation) {
  const std::string dir = test::makeTempDir("cli_run_octomap_absent");
  ASSERT_EQ(
      run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 6 --seed 5 -q").exit_code,
      0);
  // No sidecar: "octomap": {"absent": ...} names what is missing.
  fs::rename(dir + "/s.world.yaml", dir + "/kept.world.yaml");
  const RunResult none = run("run " + dir + "/s.rawlog -o " + dir + "/none -q --no-pictures");
  ASSERT_EQ(none.exit_code, 0) << none.output;
  const std::string m_none = readFile(dir + "/none/metrics.json");
  EXPECT_NE(m_none.find("\"octomap\": {\"absent\": \"no world file"), std::string::npos) << m_none;
  EXPECT_NE(m_none.find("s.world.yaml"), std::string::npos) << m_none;
  // An unreadable sidecar: a warning, and the reason in metrics.json.
  {
    std::ofstream bad(dir + "/s.world.yaml");
    bad << "shapes: [ {type: plane\n";
  }
  const RunResult bad = run("run " + dir + "/s.rawlog -o " + dir + "/bad -q --no-pictures");
  ASSERT_EQ(bad.exit_code, 0) << bad.output;
  EXPECT_NE(bad.error.find("no map evaluation"), std::string::npos) << bad.error;
  const std::string m_bad = readFile(dir + "/bad/metrics.json");
  EXPECT_NE(m_bad.find("\"absent\": \""), std::string::npos) << m_bad;
  EXPECT_NE(m_bad.find("s.world.yaml"), std::string::npos) << m_bad;
  EXPECT_FALSE(fs::exists(dir + "/bad/map_eval_voxels.csv"));
}

TEST(TwocamCli, RunRefusesANonFiniteGroundTruthPose) {
  // Before: the NaN reached the distinct-points count (a float-to-int conversion of NaN,
  // undefined behaviour that UBSan aborts on; Release went on with exit 0).
  const std::string dir = test::makeTempDir("cli_run_nan_truth");
  ASSERT_EQ(
      run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 6 --seed 5 -q").exit_code,
      0);
  ASSERT_TRUE(rewriteLog(dir + "/s.rawlog", dir + "/nan.rawlog", [](io::LogFrame* f) {
                if (f->index == 3 && f->ground_truth) {
                  f->ground_truth->T_w_b.translation().y() =
                      std::numeric_limits<double>::quiet_NaN();
                }
              }).isOk());
  const RunResult r = run("run " + dir + "/nan.rawlog -o " + dir + "/out -q --no-pictures");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.error.find("frame 3: ground-truth pose has a non-finite entry"), std::string::npos)
      << r.error;
  EXPECT_FALSE(fs::exists(dir + "/out"));
}

TEST(TwocamCli, RunDrawsPictures) {
  if (!fs::exists("/usr/bin/python3"))
    GTEST_SKIP() << "no /usr/bin/python3: pictures need Debian's python3-matplotlib";
  const std::string dir = test::makeTempDir("cli_run_pictures");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 12 --seed 5 -q")
                .exit_code,
            0);
  const RunResult r = run("run " + dir + "/s.rawlog -o " + dir + "/out -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  if (r.error.find("No module named") != std::string::npos)
    GTEST_SKIP() << "matplotlib missing: " << r.error;
  for (const char* f :
       {"map_topdown.png", "confidence_histogram.png", "timings.png", "sample_frame.png"}) {
    EXPECT_TRUE(fs::exists(dir + "/out/pictures/" + f)) << f << "\n" << r.output;
  }
}

// ---- stereo-eval ----------------------------------------------------------------------------

/// Writes an 8-bit binary PGM (P5). OpenCV's image reader, which the tool uses, reads PGM as
/// well as PNG; this test binary does not link OpenCV itself.
void writePgm(const std::string& path, int width, int height, const std::vector<uint8_t>& pixels) {
  std::ofstream f(path, std::ios::binary);
  f << "P5\n" << width << " " << height << "\n255\n";
  f.write(reinterpret_cast<const char*>(pixels.data()),
          static_cast<std::streamsize>(pixels.size()));
}

constexpr int kPairWidth = 160;
constexpr int kPairHeight = 120;
constexpr int kPairDisparityPx = 5;
constexpr int kPairGtScale = 4;

/// Files of a synthetic rectified pair: seeded random texture in 2x2 blocks, right = left
/// shifted by a constant disparity, so left pixel u matches right pixel u - d.
struct SyntheticPair {
  std::string left, right, gt;
};

SyntheticPair writeSyntheticPair(const std::string& dir,
                                 int width = kPairWidth,
                                 int height = kPairHeight) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> grey(0, 255);
  const int tex_width = width + kPairDisparityPx;
  std::vector<uint8_t> texture(static_cast<size_t>(tex_width) * height);
  for (int v = 0; v < height; v += 2) {
    for (int u = 0; u < tex_width; u += 2) {
      const auto g = static_cast<uint8_t>(grey(rng));
      for (int dv = 0; dv < 2 && v + dv < height; ++dv) {
        for (int du = 0; du < 2 && u + du < tex_width; ++du)
          texture[(v + dv) * tex_width + u + du] = g;
      }
    }
  }
  std::vector<uint8_t> left(static_cast<size_t>(width) * height), right(left.size()),
      gt(left.size());
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      left[v * width + u] = texture[v * tex_width + u];
      right[v * width + u] = texture[v * tex_width + u + kPairDisparityPx];
      // The leftmost columns have no match in the right image: 0 = no ground truth.
      gt[v * width + u] = u < kPairDisparityPx ? 0 : kPairDisparityPx * kPairGtScale;
    }
  }
  SyntheticPair p{dir + "/left.pgm", dir + "/right.pgm", dir + "/gt.pgm"};
  writePgm(p.left, width, height, left);
  writePgm(p.right, width, height, right);
  writePgm(p.gt, width, height, gt);
  return p;
}

/// Parses a flat JSON object of numbers (null = NaN), as stereo-eval writes; nullopt when the
/// text is not such an object.
std::optional<std::map<std::string, double>> parseFlatJson(const std::string& text) {
  std::map<std::string, double> values;
  size_t i = 0;
  auto skip_space = [&] {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  };
  auto expect = [&](char c) {
    skip_space();
    if (i >= text.size() || text[i] != c) return false;
    ++i;
    return true;
  };
  if (!expect('{')) return std::nullopt;
  skip_space();
  if (i < text.size() && text[i] == '}') {
    ++i;
  } else {
    while (true) {
      if (!expect('"')) return std::nullopt;
      const size_t end = text.find('"', i);
      if (end == std::string::npos) return std::nullopt;
      const std::string key = text.substr(i, end - i);
      i = end + 1;
      if (!expect(':')) return std::nullopt;
      skip_space();
      double value = 0.0;
      if (text.compare(i, 4, "null") == 0) {
        value = std::numeric_limits<double>::quiet_NaN();
        i += 4;
      } else {
        const char* begin = text.c_str() + i;
        char* stop = nullptr;
        value = std::strtod(begin, &stop);
        if (stop == begin) return std::nullopt;
        i += static_cast<size_t>(stop - begin);
      }
      if (!values.emplace(key, value).second) return std::nullopt;  // duplicate key
      if (expect(',')) continue;
      if (expect('}')) break;
      return std::nullopt;
    }
  }
  skip_space();
  if (i != text.size()) return std::nullopt;
  return values;
}

/// Reads the width and height of a PNG after checking its signature, header chunk and end
/// chunk; false when the file is not a well-formed PNG.
bool pngSize(const std::string& path, int* width, int* height) {
  const std::string b = readFile(path);
  static const std::string kSignature = "\x89PNG\r\n\x1a\n";
  static const std::string kEnd = std::string("IEND\xae\x42\x60\x82", 8);
  if (b.size() < 8 + 25 + 12 || b.compare(0, 8, kSignature) != 0) return false;
  if (b.compare(12, 4, "IHDR") != 0 || b.compare(b.size() - 8, 8, kEnd) != 0) return false;
  if (b.find("IDAT") == std::string::npos) return false;
  auto be32 = [&](size_t at) {
    uint32_t x = 0;
    for (size_t k = 0; k < 4; ++k) x = (x << 8) | static_cast<unsigned char>(b[at + k]);
    return static_cast<int>(x);
  };
  *width = be32(16);
  *height = be32(20);
  return *width > 0 && *height > 0;
}

std::string stereoEvalArgs(const SyntheticPair& p, const std::string& extra) {
  return "stereo-eval --left " + p.left + " --right " + p.right + " --gt " + p.gt + " --gt-scale " +
         std::to_string(kPairGtScale) + " " + extra;
}

TEST(TwocamCli, StereoEvalSyntheticPairBothModes) {
  const std::string dir = test::makeTempDir("cli_stereo_eval_good");
  const SyntheticPair pair = writeSyntheticPair(dir);
  for (const std::string mode : {"dense", "salient"}) {
    SCOPED_TRACE(mode);
    const std::string json_path = dir + "/" + mode + ".json";
    const std::string image_path = dir + "/" + mode + ".png";
    const RunResult r = run(stereoEvalArgs(
        pair, "--max-disp 16 --mode " + mode + " -o " + json_path + " --image " + image_path));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.error, "");
    ASSERT_TRUE(fs::is_regular_file(json_path));
    const auto json = parseFlatJson(readFile(json_path));
    ASSERT_TRUE(json.has_value()) << readFile(json_path);
    for (const char* key : {"bad1",
                            "bad2",
                            "bad0.5",
                            "avgerr",
                            "density",
                            "recall_at_k",
                            "points",
                            "ms",
                            "s_per_mp"}) {
      EXPECT_EQ(json->count(key), 1u) << "missing key " << key;
    }
    const auto value = [&](const char* key) {
      const auto it = json->find(key);
      return it == json->end() ? std::numeric_limits<double>::quiet_NaN() : it->second;
    };
    EXPECT_GT(value("points"), 0.0);
    EXPECT_GT(value("ms"), 0.0);
    EXPECT_GT(value("s_per_mp"), 0.0);
    EXPECT_GE(value("bad2"), 0.0);
    EXPECT_LE(value("bad2"), value("bad1"));
    EXPECT_GE(value("bad0.5"), value("bad1"));
    if (mode == "dense") {
      EXPECT_EQ(value("points"), kPairWidth * kPairHeight);
      EXPECT_LE(value("bad1"), 2.0);
      EXPECT_GT(value("density"), 50.0);
      EXPECT_LE(value("avgerr"), 0.5);
    } else {
      EXPECT_GE(value("recall_at_k"), 95.0);
      EXPECT_LE(value("bad1"), 5.0);
    }
    int width = 0, height = 0;
    EXPECT_TRUE(pngSize(image_path, &width, &height)) << image_path << " is not a well-formed PNG";
    EXPECT_GE(width, kPairWidth);
    EXPECT_GE(height, kPairHeight);
  }
}

TEST(TwocamCli, StereoEvalNccMatcherReportsScaleSharesAndPicture) {
  const std::string dir = test::makeTempDir("cli_stereo_eval_ncc");
  const SyntheticPair pair = writeSyntheticPair(dir);
  for (const std::string mode : {"dense", "salient"}) {
    SCOPED_TRACE(mode);
    const std::string json_path = dir + "/" + mode + ".json";
    const std::string scale_path = dir + "/" + mode + "_scales.png";
    const RunResult r = run(stereoEvalArgs(pair,
                                           "--max-disp 16 --mode " + mode + " --matcher ncc -o " +
                                               json_path + " --scale-image " + scale_path));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto json = parseFlatJson(readFile(json_path));
    ASSERT_TRUE(json.has_value()) << readFile(json_path);
    double share_sum = 0.0;
    for (const char* key : {"scale_share_0.707", "scale_share_1", "scale_share_1.414"}) {
      ASSERT_EQ(json->count(key), 1u) << "missing key " << key;
      share_sum += json->at(key);
    }
    EXPECT_NEAR(share_sum, 100.0, 1e-6);
    EXPECT_GT(json->at("scale_share_1"), 50.0) << "fronto-parallel layers: mostly square";
    EXPECT_LE(json->at("bad1"), mode == "dense" ? 2.0 : 5.0);
    EXPECT_GT(json->at("density"), 50.0);
    int width = 0, height = 0;
    EXPECT_TRUE(pngSize(scale_path, &width, &height)) << scale_path;
    EXPECT_EQ(width, kPairWidth);
    EXPECT_EQ(height, kPairHeight);
  }
}

/// Runs stereo-eval with a JSON output and expects a non-zero exit, an error on stderr that
/// mentions every part of `cause` (the offending file or flag, and what is wrong with it), and
/// no JSON file.
void expectStereoEvalRejected(const std::string& args,
                              const std::string& json_path,
                              const std::vector<std::string>& cause) {
  SCOPED_TRACE(args);
  const RunResult r = run(args + " -o " + json_path);
  EXPECT_NE(r.exit_code, 0) << r.output;
  for (const std::string& part : cause) {
    EXPECT_NE(r.error.find(part), std::string::npos)
        << "stderr should mention '" << part << "': " << r.error;
  }
  EXPECT_FALSE(fs::exists(json_path)) << "no JSON may be written";
}

TEST(TwocamCli, StereoEvalMatcherSupport) {
  const std::string dir = test::makeTempDir("cli_stereo_eval_support");
  const SyntheticPair pair = writeSyntheticPair(dir);
  for (const std::string mode : {"dense", "salient"}) {
    SCOPED_TRACE(mode);
    const std::string json_path = dir + "/" + mode + ".json";
    const RunResult r = run(stereoEvalArgs(
        pair, "--max-disp 16 --matcher support --mode " + mode + " -o " + json_path));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto json = parseFlatJson(readFile(json_path));
    ASSERT_TRUE(json.has_value()) << readFile(json_path);
    EXPECT_LE(json->at("bad1"), 5.0);
    EXPECT_GT(json->at("density"), 50.0);
  }
  const RunResult none = run(stereoEvalArgs(
      pair, "--max-disp 16 --matcher support --mode dense --fill none -o " + dir + "/none.json"));
  EXPECT_EQ(none.exit_code, 0) << none.output;
  const std::string json = dir + "/bad.json";
  expectStereoEvalRejected(stereoEvalArgs(pair, "--max-disp 16 --mode dense --matcher census"),
                           json,
                           {"--matcher", "sad, support", "census"});
  expectStereoEvalRejected(
      stereoEvalArgs(pair, "--max-disp 16 --mode dense --matcher support --fill cubic"),
      json,
      {"--fill", "cubic"});
  expectStereoEvalRejected(
      stereoEvalArgs(pair, "--max-disp 16 --mode dense --fill none"), json, {"--fill", "support"});
}

// The salient figures docs/frontend.md quotes for Middlebury, pinned: the binary must keep
// giving them (the command is deterministic; the tolerance only absorbs the printed rounding).
TEST(TwocamCli, StereoEvalSalientGivesTheDocumentedMiddleburyFigures) {
  TWOCAM_REQUIRE_SHARED_DATA(data);
  constexpr double kPrintedTol = 0.006;  // the JSON's 10 digits against 2 decimals here
  struct Row {
    const char* scene;
    const char* files;
    bool exclude_occluded;
    double points, evaluated, recall_at_k, recall_at_1, bad1, density;
  };
  const std::string m = data + "/middlebury";
  const std::string tsukuba = "--left " + m + "/tsukuba/im3.png --right " + m +
                              "/tsukuba/im4.png --gt " + m +
                              "/tsukuba/disp3.pgm --gt-scale 16 --max-disp 16";
  const std::string venus = "--left " + m + "/venus/im2.png --right " + m + "/venus/im6.png --gt " +
                            m + "/venus/disp2.pgm --gt-scale 8 --max-disp 20";
  const Row rows[] = {
      {"tsukuba", tsukuba.c_str(), false, 360, 343, 90.38, 83.67, 7.00, 82.51},
      {"tsukuba", tsukuba.c_str(), true, 360, 320, 95.00, 89.06, 4.38, 84.69},
      {"venus", venus.c_str(), false, 541, 541, 95.75, 94.27, 0.74, 90.39},
      {"venus", venus.c_str(), true, 541, 520, 99.42, 97.88, 0.58, 93.85},
  };
  for (const Row& row : rows) {
    const std::string args = std::string("stereo-eval ") + row.files + " --mode salient" +
                             (row.exclude_occluded ? " --exclude-occluded" : "");
    SCOPED_TRACE(args);
    const RunResult r = run(args);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string out = r.output.substr(0, r.output.size() - r.error.size());
    const io::Json j = io::Json::parse(out);
    EXPECT_EQ(j.at("points").get<double>(), row.points);
    EXPECT_EQ(j.at("evaluated").get<double>(), row.evaluated);
    EXPECT_NEAR(j.at("recall_at_k").get<double>(), row.recall_at_k, kPrintedTol);
    EXPECT_NEAR(j.at("recall_at_1").get<double>(), row.recall_at_1, kPrintedTol);
    EXPECT_NEAR(j.at("bad1").get<double>(), row.bad1, kPrintedTol);
    EXPECT_NEAR(j.at("density").get<double>(), row.density, kPrintedTol);
  }
}

TEST(TwocamCli, StereoEvalOpenCvReferencesScoreTheSyntheticPair) {
  const std::string dir = test::makeTempDir("cli_stereo_eval_opencv");
  const SyntheticPair pair = writeSyntheticPair(dir);
  for (const std::string matcher : {"opencv-bm", "opencv-sgbm"}) {
    SCOPED_TRACE(matcher);
    const std::string json_path = dir + "/" + matcher + ".json";
    const RunResult r = run(stereoEvalArgs(
        pair, "--max-disp 16 --mode dense --matcher " + matcher + " -o " + json_path));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const io::Json j = io::Json::parse(readFile(json_path));
    EXPECT_GT(j.at("density").get<double>(), 0.0);
    EXPECT_LE(j.at("bad1").get<double>(), j.at("density").get<double>());
  }
}

TEST(TwocamCli, StereoEvalBadInputGivesClearErrorAndNoJson) {
  const std::string dir = test::makeTempDir("cli_stereo_eval_bad");
  const SyntheticPair pair = writeSyntheticPair(dir);
  constexpr int kNarrowWidth = kPairWidth - 10;
  fs::create_directories(dir + "/narrow");
  const SyntheticPair narrow = writeSyntheticPair(dir + "/narrow", kNarrowWidth, kPairHeight);
  const std::string narrow_size = std::to_string(kNarrowWidth) + "x" + std::to_string(kPairHeight);
  const std::string json = dir + "/out.json";
  const std::string ok_flags = "--max-disp 16 --mode dense";
  const std::string garbage_file = dir + "/garbage.pgm";
  {
    std::mt19937 rng(3);
    std::string garbage(4096, '\0');
    for (char& c : garbage) c = static_cast<char>(rng() & 0xff);
    std::ofstream(garbage_file, std::ios::binary) << garbage;
  }

  SyntheticPair mixed = pair;
  mixed.right = narrow.right;
  expectStereoEvalRejected(stereoEvalArgs(mixed, ok_flags), json, {narrow_size, "differ in size"});

  SyntheticPair gt_size = pair;
  gt_size.gt = narrow.gt;
  expectStereoEvalRejected(stereoEvalArgs(gt_size, ok_flags), json, {narrow.gt, narrow_size});

  SyntheticPair missing = pair;
  missing.left = dir + "/no_such_left.png";
  expectStereoEvalRejected(stereoEvalArgs(missing, ok_flags), json, {missing.left, "no such file"});

  SyntheticPair unreadable = pair;
  unreadable.right = garbage_file;
  expectStereoEvalRejected(stereoEvalArgs(unreadable, ok_flags), json, {garbage_file, "readable"});

  SyntheticPair corrupt = pair;
  corrupt.gt = garbage_file;
  expectStereoEvalRejected(stereoEvalArgs(corrupt, ok_flags), json, {garbage_file, "readable"});

  expectStereoEvalRejected(stereoEvalArgs(pair, "--max-disp 0 --mode dense"), json, {"--max-disp"});
  expectStereoEvalRejected(
      stereoEvalArgs(pair, "--max-disp 200 --mode dense"), json, {"--max-disp", "width"});
  expectStereoEvalRejected(
      stereoEvalArgs(pair, "--max-disp 16 --mode other"), json, {"--mode", "other"});
  expectStereoEvalRejected(stereoEvalArgs(pair, ok_flags + " --birchfield-tomasi"),
                           json,
                           {"--birchfield-tomasi", "salient"});

  expectStereoEvalRejected(
      stereoEvalArgs(pair, ok_flags + " --post ''"), json, {"--post", "empty", "none"});
  expectStereoEvalRejected(stereoEvalArgs(pair, "--max-disp 300 --mode dense"),
                           json,
                           {"--max-disp 300", "256 disparities"});
  expectStereoEvalRejected(stereoEvalArgs(pair, ok_flags + " --window 8"), json, {"--window"});
  expectStereoEvalRejected(stereoEvalArgs(pair, "--max-disp 16 --mode salient --matcher opencv-bm"),
                           json,
                           {"opencv-bm", "--mode dense only"});
  expectStereoEvalRejected(stereoEvalArgs(pair, ok_flags + " --matcher zncc"),
                           json,
                           {"--matcher", "sad, support, ncc, maxtree, opencv-bm", "zncc"});
  expectStereoEvalRejected(stereoEvalArgs(pair, ok_flags + " --matcher ncc --post none"),
                           json,
                           {"--post", "--matcher sad"});
  expectStereoEvalRejected(stereoEvalArgs(pair, ok_flags + " --scale-image " + dir + "/s.png"),
                           json,
                           {"--scale-image", "--matcher ncc"});
  expectStereoEvalRejected(
      stereoEvalArgs(pair, ok_flags + " --matcher ncc --scale-image " + dir + "/s.xyz"),
      json,
      {"--scale-image", "xyz"});

  const std::string mask = dir + "/narrow_mask.pgm";
  writePgm(mask,
           kNarrowWidth,
           kPairHeight,
           std::vector<uint8_t>(static_cast<size_t>(kNarrowWidth) * kPairHeight, 255));
  expectStereoEvalRejected(
      stereoEvalArgs(pair, ok_flags + " --mask " + mask), json, {mask, "size"});

  expectStereoEvalRejected(stereoEvalArgs(pair, ok_flags),
                           "/nonexistent_twocam_dir/out.json",
                           {"/nonexistent_twocam_dir", "does not exist"});
}

TEST(TwocamCli, StereoEvalMatcherOptionDispatchesAndRejectsUnknownValues) {
  const std::string dir = test::makeTempDir("cli_stereo_eval_matcher");
  const SyntheticPair pair = writeSyntheticPair(dir);
  for (const std::string mode : {"dense", "sparse", "salient"}) {
    SCOPED_TRACE(mode);
    const std::string json_path = dir + "/maxtree_" + mode + ".json";
    const RunResult r = run(stereoEvalArgs(
        pair, "--max-disp 16 --matcher maxtree --mode " + mode + " -o " + json_path));
    ASSERT_EQ(r.exit_code, 0) << r.output << r.error;
    const auto json = parseFlatJson(readFile(json_path));
    ASSERT_TRUE(json.has_value()) << readFile(json_path);
    EXPECT_EQ(json->count("density"), 1u);
    EXPECT_EQ(json->count("s_per_mp"), 1u);
  }
  const std::string json = dir + "/out.json";
  expectStereoEvalRejected(stereoEvalArgs(pair, "--max-disp 16 --mode dense --matcher other"),
                           json,
                           {"--matcher", "other", "sad", "maxtree"});
  expectStereoEvalRejected(
      stereoEvalArgs(pair, "--max-disp 16 --mode sparse"), json, {"--mode sparse", "maxtree"});
  expectStereoEvalRejected(
      stereoEvalArgs(pair, "--max-disp 16 --mode dense --matcher maxtree --window 9"),
      json,
      {"--window", "sad"});
}

/// Middlebury Tsukuba (scale 16, 0 = no ground truth); the accuracy targets.
struct TsukubaResult {
  RunResult run;
  std::optional<std::map<std::string, double>> json;
};
TsukubaResult runTsukuba(const std::string& data_dir,
                         const std::string& out_dir,
                         const std::string& extra) {
  const std::string set = data_dir + "/middlebury/tsukuba";
  const std::string json_path = out_dir + "/metrics.json";
  fs::remove(json_path);
  TsukubaResult t;
  t.run = run("stereo-eval --left " + set + "/im3.png --right " + set + "/im4.png --gt " + set +
              "/disp3.pgm --gt-scale 16 --max-disp 16 -o " + json_path + " " + extra);
  if (t.run.exit_code == 0) t.json = parseFlatJson(readFile(json_path));
  return t;
}

TEST(TwocamCli, StereoEvalTsukubaMeetsTargets) {
  TWOCAM_REQUIRE_SHARED_DATA(data_dir);
  const std::string dir = test::makeTempDir("cli_stereo_eval_tsukuba");

  const TsukubaResult salient = runTsukuba(data_dir, dir, "--mode salient --exclude-occluded");
  ASSERT_EQ(salient.run.exit_code, 0) << salient.run.output;
  ASSERT_TRUE(salient.json.has_value());
  EXPECT_GE(salient.json->at("recall_at_k"), 95.0);
  EXPECT_LE(salient.json->at("bad1"), 5.0);

  const TsukubaResult dense = runTsukuba(data_dir, dir, "--mode dense");
  ASSERT_EQ(dense.run.exit_code, 0) << dense.run.output;
  ASSERT_TRUE(dense.json.has_value());
  EXPECT_LE(dense.json->at("bad1"), 10.0);
}

TEST(TwocamCli, RunWithAWorkingSetKeepsTheTrackerBoundedAndTheMapWhole) {
  const std::string dir = test::makeTempDir("cli_run_working_set");
  ASSERT_EQ(run("simulate " + smallWorld() + " -o " + dir + "/s.rawlog --frames 90 -q").exit_code,
            0);
  const std::string log = dir + "/s.rawlog";
  const auto metrics = [&](const std::string& out) {
    return io::Json::parse(readFile(dir + "/" + out + "/metrics.json"));
  };
  const auto map_rows = [&](const std::string& map) {
    std::unique_ptr<store::LandmarkStore> st;
    store::StoreInfo info;
    EXPECT_TRUE(store::LandmarkStore::open(map, store::OpenMode::kReadOnly, &st));
    EXPECT_TRUE(st->info(&info));
    EXPECT_TRUE(st->integrityCheck());
    return info.landmark_count;
  };
  // Without a working set, and with one whose radius holds the whole world: the same run.
  ASSERT_EQ(
      run("run " + log + " -o " + dir + "/all -q --no-pictures --map " + dir + "/all.db").exit_code,
      0);
  ASSERT_EQ(run("run " + log + " -o " + dir + "/wide -q --no-pictures --map " + dir +
                "/wide.db --working-set-radius 1000")
                .exit_code,
            0);
  const io::Json all = metrics("all");
  const io::Json wide = metrics("wide");
  EXPECT_EQ(wide["working_set"]["paged_out"].get<int64_t>(), 0) << wide["working_set"].dump();
  EXPECT_EQ(wide["landmarks"].dump(), all["landmarks"].dump());
  EXPECT_EQ(wide["trajectory"].dump(), all["trajectory"].dump());
  EXPECT_EQ(all.count("working_set"), 0u);

  // A cap far below what the run confirms: landmarks out of view leave for the map (those in
  // view stay, so the cap is exceeded by the view), the tracker holds far fewer than the run
  // confirmed, the map keeps every landmark the run wrote (its summary line) and passes SQLite's
  // integrity check, and the run confirms about what it confirms with everything in memory
  // (nothing in view is paged out and confirmed again).
  constexpr int kCap = 300;
  const RunResult capped = run("run " + log + " -o " + dir + "/cap -q --no-pictures --map " + dir +
                               "/cap.db --working-set-max " + std::to_string(kCap));
  ASSERT_EQ(capped.exit_code, 0) << capped.output << capped.error;
  const io::Json cap = metrics("cap");
  const io::Json& ws = cap["working_set"];
  EXPECT_GT(ws["paged_out"].get<int64_t>(), 0) << ws.dump();
  const int all_confirmed = all["landmarks"]["confirmed"].get<int>();
  EXPECT_GT(all_confirmed, 2 * kCap);
  EXPECT_LT(ws["max_confirmed"].get<int>(), 0.75 * all_confirmed) << ws.dump();
  EXPECT_LT(cap["landmarks"]["confirmed"].get<int>(), 1.05 * all_confirmed);
  const std::string written = "map: ";
  const size_t at = capped.output.find(written);
  ASSERT_NE(at, std::string::npos) << capped.output;
  const int64_t in_summary = std::stoll(capped.output.substr(at + written.size()));
  EXPECT_EQ(map_rows(dir + "/cap.db"), in_summary);
  // The landmark metrics judge every landmark the run made, paged out or not: about as many
  // as without the working set (not only those left in the tracker).
  EXPECT_GT(cap["landmarks"]["confirmed"].get<int>(), 0.95 * all_confirmed);
  // Deterministic: the same run again gives the same counts.
  ASSERT_EQ(run("run " + log + " -o " + dir + "/cap2 -q --no-pictures --map " + dir +
                "/cap2.db --working-set-max " + std::to_string(kCap))
                .exit_code,
            0);
  EXPECT_EQ(metrics("cap2")["working_set"].dump(), ws.dump());
  EXPECT_EQ(metrics("cap2")["landmarks"].dump(), cap["landmarks"].dump());

  // A radius smaller than the view: landmarks behind the robot leave, those ahead come back.
  ASSERT_EQ(run("run " + log + " -o " + dir + "/near -q --no-pictures --map " + dir +
                "/near.db --working-set-radius 1.5")
                .exit_code,
            0);
  const io::Json near_metrics = metrics("near");
  const io::Json& near = near_metrics["working_set"];
  EXPECT_GT(near["paged_out"].get<int64_t>(), 0);
  // The index finds more ids than the rows the tracker lacked.
  EXPECT_GE(near["ids_read"].get<int64_t>(), near["rows_read"].get<int64_t>()) << near.dump();

  // Bad input: a working set without a map, a negative radius.
  const RunResult no_map =
      run("run " + log + " -o " + dir + "/x1 -q --no-pictures --working-set-radius 5");
  EXPECT_NE(no_map.exit_code, 0);
  EXPECT_NE(no_map.error.find("--working-set-radius and --working-set-max need --map"),
            std::string::npos)
      << no_map.error;
  const RunResult negative = run("run " + log + " -o " + dir + "/x2 -q --no-pictures --map " + dir +
                                 "/x2.db --working-set-radius -1");
  EXPECT_NE(negative.exit_code, 0);
  EXPECT_NE(negative.error.find("--working-set-radius: -1"), std::string::npos) << negative.error;
  EXPECT_FALSE(fs::exists(dir + "/x2.db"));
}

}  // namespace
}  // namespace twocam
