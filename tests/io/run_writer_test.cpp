#include "io/run_writer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "io/json.h"
#include "support/command.h"
#include "support/test_paths.h"

namespace twocam::io {
namespace {

namespace fs = std::filesystem;
using test::readFile;

void put(const fs::path& path, const std::string& content) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << content;
}

/// Every entry below `dir` (relative path -> content; folders as "<dir>").
std::map<std::string, std::string> tree(const fs::path& dir) {
  std::map<std::string, std::string> t;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string rel = fs::relative(e.path(), dir).string();
    t[rel] = e.is_directory() ? "<dir>" : readFile(e.path().string());
  }
  return t;
}

/// Hidden staging folders left in `parent`.
int leftovers(const fs::path& parent) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(parent))
    n += e.path().filename().string().find(".staging-") != std::string::npos;
  return n;
}

TEST(RunWriter, ReplacesAnEarlierRunOnlyOnCommit) {
  const fs::path dir = test::makeTempDir("run_writer_commit");
  const fs::path out = dir / "run";
  put(out / "metrics.json", "{\"old\": 1}\n");
  put(out / "sample_frame/left.png", "old png");
  put(out / "stale.csv", "from the earlier run");
  std::unique_ptr<RunWriter> w;
  ASSERT_TRUE(RunWriter::begin(out.string(), {}, {}, &w).isOk());
  ASSERT_TRUE(w->writeFile("landmarks.csv", "id\n").isOk());
  ASSERT_TRUE(w->writeFile("sample_frame/hypotheses.csv", "frame\n").isOk());
  ASSERT_TRUE(w->writeJson("metrics.json", Json{{"new", 2}}, kMetricsJsonDigits).isOk());
  // Nothing visible before the commit.
  EXPECT_EQ(readFile((out / "metrics.json").string()), "{\"old\": 1}\n");
  ASSERT_TRUE(w->commit().isOk());
  const auto t = tree(out);
  EXPECT_EQ(t.at("metrics.json"), "{\n  \"new\": 2\n}\n");
  EXPECT_EQ(t.at("landmarks.csv"), "id\n");
  EXPECT_EQ(t.count("stale.csv"), 0u);  // the folder is replaced as a whole
  EXPECT_EQ(t.count("sample_frame/left.png"), 0u);
  EXPECT_EQ(t.count("landmarks.csv.partial"), 0u);
  w.reset();
  EXPECT_EQ(leftovers(dir), 0);
}

TEST(RunWriter, AFailureBeforeCommitLeavesTheEarlierRunByteForByte) {
  const fs::path dir = test::makeTempDir("run_writer_fail");
  const fs::path out = dir / "run";
  put(out / "metrics.json", "{\"old\": 1}\n");
  put(out / "map.bt", std::string("\x00\x01\x02", 3));
  put(out / "sample_frame/left.png", "old png");
  const auto before = tree(out);
  {
    std::unique_ptr<RunWriter> w;
    RunWriter::Options o;
    o.fail_write_for_tests = "sample_frame/left.png";
    ASSERT_TRUE(RunWriter::begin(out.string(), {}, o, &w).isOk());
    ASSERT_TRUE(w->writeFile("landmarks.csv", "id\n").isOk());
    const Status s = w->writeFile("sample_frame/left.png", "new");
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("sample_frame/left.png"), std::string::npos) << s.message();
  }  // no commit: the staging folder goes
  EXPECT_EQ(tree(out), before);
  EXPECT_EQ(leftovers(dir), 0);
}

TEST(RunWriter, CreatesANewFolderWithItsParents) {
  const fs::path dir = test::makeTempDir("run_writer_new");
  const fs::path out = dir / "a/b/run";
  std::unique_ptr<RunWriter> w;
  ASSERT_TRUE(RunWriter::begin(out.string(), {}, {}, &w).isOk());
  ASSERT_TRUE(w->writeFile("x.csv", "x\n").isOk());
  ASSERT_TRUE(w->commit().isOk());
  EXPECT_EQ(readFile((out / "x.csv").string()), "x\n");
  EXPECT_EQ(leftovers(out.parent_path()), 0);
}

TEST(RunWriter, RefusesOutputsThatAreInputsOrNotARunFolder) {
  const fs::path dir = test::makeTempDir("run_writer_refuse");
  put(dir / "log.rawlog", "log");
  put(dir / "log_Images/left_0.png", "img");
  put(dir / "notes/todo.txt", "mine");
  put(dir / "file", "x");
  const std::vector<std::string> inputs = {(dir / "log.rawlog").string(),
                                           (dir / "log_Images").string()};
  const auto refused = [&](const fs::path& out, const std::string& words) {
    std::unique_ptr<RunWriter> w;
    const Status s = RunWriter::begin(out.string(), inputs, {}, &w);
    EXPECT_FALSE(s.isOk()) << out;
    EXPECT_NE(s.message().find(words), std::string::npos) << s.message();
    EXPECT_EQ(w, nullptr);
  };
  refused(dir / "log.rawlog", "is the input");
  refused(dir / "log_Images", "is the input");
  refused(dir / "log_Images/", "is the input");
  refused(dir / "log_Images/../log_Images/out", "inside the input folder");
  refused(dir, "contains the input");
  refused(dir / "notes", "holds no metrics.json");
  refused(dir / "file", "not a folder");
  EXPECT_EQ(readFile((dir / "notes/todo.txt").string()), "mine");
  EXPECT_EQ(readFile((dir / "log.rawlog").string()), "log");
  EXPECT_EQ(leftovers(dir), 0);
  // An empty folder is fine.
  fs::create_directories(dir / "empty");
  std::unique_ptr<RunWriter> w;
  EXPECT_TRUE(RunWriter::begin((dir / "empty").string(), inputs, {}, &w).isOk());
}

TEST(Json, PrintsTenSignificantDigitsAndNullForNonFinite) {
  const Json j = {{"a", 0.1 + 0.2},
                  {"b", 2440.580555555},
                  {"n", numberOrNull(std::numeric_limits<double>::quiet_NaN())},
                  {"i", int64_t{49863}},
                  {"zero", 0.0},
                  {"s", "a\"b"},
                  {"nested", {{"x", 1.5}, {"list", Json::array({1, 2})}}}};
  EXPECT_EQ(
      toJsonText(j, 10),
      "{\n  \"a\": 0.3,\n  \"b\": 2440.580556,\n  \"n\": null,\n  \"i\": 49863,\n"
      "  \"zero\": 0,\n  \"s\": \"a\\\"b\",\n  \"nested\": {\"x\": 1.5, \"list\": [1, 2]}\n}\n");
  EXPECT_EQ(toJsonText(Json(std::numeric_limits<double>::infinity()), 10), "null\n");
  EXPECT_EQ(toJsonText(Json(12.3456789), 6), "12.3457\n");
}

TEST(Json, BreaksContainersOfMoreThanTwelveMembersOverLines) {
  Json small = Json::object(), big = Json::object();
  for (int i = 0; i < 12; ++i) small["k" + std::to_string(i)] = i;
  for (int i = 0; i < 13; ++i) big["k" + std::to_string(i)] = i;
  const std::string text = toJsonText(Json{{"small", small}, {"big", big}}, 10);
  EXPECT_NE(text.find("\"small\": {\"k0\": 0, \"k1\": 1,"), std::string::npos) << text;
  EXPECT_NE(text.find("\"big\": {\n    \"k0\": 0,\n    \"k1\": 1,"), std::string::npos) << text;
  EXPECT_NE(text.find("\n    \"k12\": 12\n  }\n}\n"), std::string::npos) << text;
}

}  // namespace
}  // namespace twocam::io
