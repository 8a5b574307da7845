// `twocam map info` and `twocam map export`, run as a user would (the built binary).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>

#include "store/landmark_store.h"
#include "support/command.h"
#include "support/test_paths.h"

namespace twocam::store {
namespace {

namespace fs = std::filesystem;

constexpr uint64_t kSeed = 7;

test::CommandResult twocam(const std::string& args) {
  return test::runCommand(std::string(TWOCAM_BINARY) + " " + args);
}

/// Two sessions: 30 landmarks and 3 keyframes, then 20 landmarks and 2 keyframes.
std::string makeMap(const std::string& dir) {
  const std::string path = dir + "/map.db";
  std::unique_ptr<LandmarkStore> store;
  EXPECT_TRUE(LandmarkStore::open(path, OpenMode::kCreateOrExtend, &store).isOk());
  std::mt19937_64 rng(kSeed);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  uint64_t id = 1;
  for (const auto& [log, landmarks, keyframes] :
       {std::tuple{"/logs/office_1.rawlog", 30, 3}, std::tuple{"/logs/office_2.rawlog", 20, 2}}) {
    int32_t session = 0;
    EXPECT_TRUE(store->beginSession("rig", "config", log, &session).isOk());
    StoreBatch batch;
    for (int i = 0; i < landmarks; ++i) {
      StoredLandmark l;
      l.id = id++;
      l.p_m = {u(rng), u(rng), u(rng)};
      l.session = session;
      batch.upserts.push_back(l);
    }
    for (int f = 0; f < keyframes; ++f) {
      StoredKeyframe k;
      k.session = session;
      k.frame = f;
      batch.keyframes.push_back(k);
    }
    EXPECT_TRUE(store->writeBatch(batch).isOk());
  }
  return path;
}

TEST(MapCommand, InfoPrintsWhatTheMapHolds) {
  const std::string path = makeMap(test::makeTempDir("map_info"));
  const std::string before = test::readFile(path);
  const test::CommandResult r = twocam("map info " + path);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  for (const char* expected : {"schema version: 1",
                               "sessions: 2",
                               "/logs/office_1.rawlog, 3 keyframes",
                               "/logs/office_2.rawlog, 2 keyframes",
                               "landmarks: 50 (next id 51)",
                               "keyframes: 5",
                               "bounding box [m]: x ",
                               "file: "}) {
    EXPECT_NE(r.out.find(expected), std::string::npos) << expected << " missing in:\n" << r.out;
  }
  EXPECT_EQ(test::readFile(path), before);
}

TEST(MapCommand, ExportWritesPlyAndMrptFiles) {
  const std::string dir = test::makeTempDir("map_export");
  const std::string path = makeMap(dir);
  const std::string before = test::readFile(path);
  const test::CommandResult r =
      twocam("map export " + path + " --ply " + dir + "/map.ply --mrpt " + dir + "/map.txt");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const std::string ply = test::readFile(dir + "/map.ply");
  EXPECT_EQ(ply.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(ply.find("element vertex 50\n"), std::string::npos);
  const std::string header_end = "end_header\n";
  const size_t body = ply.find(header_end) + header_end.size();
  EXPECT_EQ(ply.size() - body, 50u * (3 * sizeof(double) + sizeof(float)));
  std::istringstream mrpt(test::readFile(dir + "/map.txt"));
  int lines = 0;
  for (std::string line; std::getline(mrpt, line);) lines += line.empty() ? 0 : 1;
  EXPECT_EQ(lines, 50);
  const test::CommandResult ascii =
      twocam("map export " + path + " --ply " + dir + "/ascii.ply --ply-ascii");
  ASSERT_EQ(ascii.exit_code, 0) << ascii.err;
  EXPECT_NE(test::readFile(dir + "/ascii.ply").find("format ascii 1.0\n"), std::string::npos);
  EXPECT_EQ(test::readFile(path), before);
}

TEST(MapCommand, ErrorsNameThePathAndExitNonZero) {
  const std::string dir = test::makeTempDir("map_errors");
  const std::string path = makeMap(dir);

  test::CommandResult r = twocam("map info " + dir + "/absent.db");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("twocam map info: error: map '" + dir + "/absent.db' does not exist"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir + "/absent.db"));

  const std::string text = dir + "/notes.txt";
  std::ofstream(text) << "not a map\n";
  r = twocam("map export " + text + " --ply " + dir + "/x.ply");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(text), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("not an SQLite database"), std::string::npos) << r.err;
  EXPECT_EQ(test::readFile(text), "not a map\n");
  EXPECT_FALSE(fs::exists(dir + "/x.ply"));

  r = twocam("map export " + path);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("--ply"), std::string::npos) << r.err;

  r = twocam("map export " + path + " --mrpt " + dir + "/no_folder/map.txt");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find(dir + "/no_folder/map.txt"), std::string::npos) << r.err;

  r = twocam("map");
  EXPECT_NE(r.exit_code, 0);
}

}  // namespace
}  // namespace twocam::store
