// The YAML kit's input guard: what reaches MRPT's parser (libfyaml) is UTF-8 text without
// control characters or directives, so that parsing always terminates.

#include "yaml/yaml_text.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <thread>

#include "support/test_paths.h"

namespace twocam::yaml {
namespace {

/// Parses on a worker thread and gives up after kParseBudget, so that a regression (a parse
/// that spins) fails the test instead of hanging the suite.
constexpr auto kParseBudget = std::chrono::seconds(10);  // a 2-byte input takes microseconds

std::optional<std::string> parseWithin(const std::string& text, bool* finished) {
  auto result = std::make_shared<std::promise<std::optional<std::string>>>();
  auto future = result->get_future();
  std::thread([text, result] {
    mrpt::containers::yaml doc;
    result->set_value(parseYaml(text, &doc));
  }).detach();
  *finished = future.wait_for(kParseBudget) == std::future_status::ready;
  if (!*finished) return std::string("(still parsing)");
  return future.get();
}

TEST(YamlText, DirectiveWithInvalidUtf8IsAnErrorNotAHang) {
  // The inputs that made libfyaml spin (found by fuzzing `twocam simulate`).
  for (const std::string& text : {std::string("%\xff", 2),
                                  std::string("\xef\xbb\xbf%\xff", 5),
                                  std::string("%YAML\xfe", 6)}) {
    bool finished = false;
    const auto error = parseWithin(text, &finished);
    ASSERT_TRUE(finished) << "parse did not finish within the budget";
    ASSERT_TRUE(error.has_value());
    EXPECT_NE(error->find("line 1, column "), std::string::npos) << *error;
  }
}

TEST(YamlText, RejectsDirectivesWithTheirLine) {
  const auto error = checkYamlText("# config\n%YAML 1.2\n---\na: 1\n");
  ASSERT_TRUE(error.has_value());
  EXPECT_EQ(*error,
            "line 2, column 1: YAML directives ('%...') are not supported; remove the line");
}

TEST(YamlText, RejectsInvalidUtf8WithItsPosition) {
  const auto error = checkYamlText("a: 1\nname: caf\xe9\n");  // Latin-1 e-acute
  ASSERT_TRUE(error.has_value());
  EXPECT_EQ(*error,
            "line 2, column 10: byte 0xe9 is not valid UTF-8 (the file must be UTF-8 text)");
  // Overlong form, a surrogate, above U+10FFFF, a truncated sequence.
  for (const std::string& bad : {std::string("a: \xc0\xaf"),
                                 std::string("a: \xed\xa0\x80"),
                                 std::string("a: \xf4\x90\x80\x80"),
                                 std::string("a: \xe2\x82")}) {
    EXPECT_TRUE(checkYamlText(bad).has_value()) << bad;
  }
}

TEST(YamlText, RejectsDeepNesting) {
  const std::string deep = "a: " + std::string(5000, '[') + std::string(5000, ']') + "\n";
  const auto error = checkYamlText(deep);
  ASSERT_TRUE(error.has_value());
  EXPECT_EQ(*error, "line 1, column 68: collections nested deeper than 64 levels");
  EXPECT_FALSE(checkYamlText("a: " + std::string(64, '[') + std::string(64, ']') + "\n"));
}

TEST(YamlText, RejectsControlCharacters) {
  const auto nul = checkYamlText(std::string("a: 1\0", 5));
  ASSERT_TRUE(nul.has_value());
  EXPECT_NE(nul->find("line 1, column 5: control character 0x00"), std::string::npos) << *nul;
  EXPECT_TRUE(checkYamlText("a: \x1b[0m").has_value());
}

TEST(YamlText, AcceptsUtf8TabsCrlfAndAByteOrderMark) {
  EXPECT_FALSE(
      checkYamlText("\xef\xbb\xbf# caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x99\x82\r\na:\t1\r\n"));
  EXPECT_FALSE(checkYamlText("a: '50%'\nb: 100 %\n"));  // % inside a line is text
  mrpt::containers::yaml doc;
  EXPECT_FALSE(parseYaml("name: caf\xc3\xa9\n", &doc));
  EXPECT_EQ(doc["name"].as<std::string>(), "caf\xc3\xa9");
}

}  // namespace
}  // namespace twocam::yaml

namespace twocam::yaml {
namespace {

TEST(YamlText, DuplicateKeysAreErrorsWithTheirLine) {
  EXPECT_EQ(findDuplicateKey("name: a\nseed: 1\nname: b\n"),
            std::optional<std::string>("line 3: duplicate key 'name' (first at line 1)"));
  // Nested and in sequence items.
  EXPECT_EQ(findDuplicateKey("rig:\n  width_px: 1\n  # c\n  width_px: 2\n"),
            std::optional<std::string>("line 4: duplicate key 'width_px' (first at line 2)"));
  EXPECT_EQ(findDuplicateKey("shapes:\n  - type: box\n    name: a\n    name: b\n"),
            std::optional<std::string>("line 4: duplicate key 'name' (first at line 3)"));
  // Flow maps, also inside sequences and over lines.
  EXPECT_EQ(findDuplicateKey("shapes:\n  - {type: box, size_m: [1, 2], type: wall}\n"),
            std::optional<std::string>("line 2: duplicate key 'type'"));
  EXPECT_EQ(findDuplicateKey("a: {b: 1,\n  c: {d: 1, d: 2}}\n"),
            std::optional<std::string>("line 2: duplicate key 'd'"));
}

TEST(YamlText, SameKeyInDifferentMapsIsFine) {
  EXPECT_FALSE(findDuplicateKey("a:\n  x: 1\nb:\n  x: 2\n"));
  EXPECT_FALSE(findDuplicateKey("s:\n  - name: a\n    t: 1\n  - name: b\n    t: 2\n"));
  EXPECT_FALSE(findDuplicateKey("s:\n  - {name: a}\n  - {name: a}\n"));
  EXPECT_FALSE(findDuplicateKey("a: |\n  x: 1\n  x: 1\nb: 'x: 1 # y'\n"));
  EXPECT_FALSE(findDuplicateKey("a: 1 # a: 2\n# a: 3\n"));
  EXPECT_FALSE(findDuplicateKey("a:\n  - 1\n  - 2\nb: [x, {c: 1}, {c: 2}]\n"));
}

TEST(YamlText, ParseYamlRejectsDuplicates) {
  mrpt::containers::yaml doc;
  const auto error = parseYaml("mapping:\n  resolution_m: 0.1\n  resolution_m: 0.2\n", &doc);
  ASSERT_TRUE(error.has_value());
  EXPECT_EQ(*error, "line 3: duplicate key 'resolution_m' (first at line 2)");
}

}  // namespace
}  // namespace twocam::yaml

namespace twocam::yaml {
namespace {

TEST(YamlText, EveryFuzzCorpusInputFinishes) {
  // The seed corpora hold the inputs fuzzing found (regress_*: a directive hang, a duplicate-key
  // scan that looped on a stray bracket).
  int files = 0;
  for (const char* corpus : {"world", "config"}) {
    const std::filesystem::path dir =
        std::filesystem::path(test::sourceDir()) / "tests/fuzz/corpus" / corpus;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
      std::ifstream in(entry.path(), std::ios::binary);
      std::stringstream text;
      text << in.rdbuf();
      bool finished = false;
      (void)parseWithin(text.str(), &finished);
      EXPECT_TRUE(finished) << entry.path() << " did not finish within the budget";
      ++files;
    }
  }
  EXPECT_GE(files, 3);
}

}  // namespace
}  // namespace twocam::yaml
