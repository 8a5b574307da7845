#include "pipeline/config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pipeline/pipeline.h"
#include "support/test_paths.h"

namespace twocam::pipeline {
namespace {

namespace fs = std::filesystem;

/// Leaf keys per section (the option structs' fields, enums included).
constexpr int kHarrisKeys = 12;      // HarrisOptions::simd comes from frontend.simd
constexpr int kSadKeys = 16;         // SalientSadOptions::simd comes from frontend.simd
constexpr int kFrontendOwnKeys = 2;  // source, simd
constexpr int kLandmarkKeys = 53;    // policy + tracker 14 + odometry_noise 5 + refine 2 +
                                     // consistency 23 + seen_count 2 + culling 3 + inlier_ratio 3
constexpr int kMappingKeys = 8;
// localization: mode, estimate_gates, update (9), slip (2), search (21), pnp (2).
constexpr int kLocalizationKeys = 36;
constexpr int kTopLevelKeys = 1;  // seed

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void writeFile(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

/// Parses `text` over the defaults and expects a failure whose message names `key_path`.
void expectError(const std::string& text,
                 const std::string& key_path,
                 const std::string& also = "") {
  PipelineConfig config;
  const Status s = parseConfigYaml(text, &config);
  ASSERT_FALSE(s.isOk()) << "accepted:\n" << text;
  EXPECT_NE(s.message().find(key_path), std::string::npos) << "message: " << s.message();
  if (!also.empty()) {
    EXPECT_NE(s.message().find(also), std::string::npos) << "message: " << s.message();
  }
  // A failed parse leaves the config as it was.
  EXPECT_EQ(toYaml(config), toYaml(PipelineConfig{}));
}

/// A leaf of toYaml's output: its dotted path and line index.
struct Leaf {
  std::string path;
  size_t line;
};

/// Splits toYaml output into lines and finds the leaf keys (lines with a value) by indentation.
std::vector<Leaf> leaves(const std::string& yaml, std::vector<std::string>* lines) {
  std::istringstream in(yaml);
  std::string line;
  std::vector<std::string> stack;
  std::vector<Leaf> out;
  while (std::getline(in, line)) {
    lines->push_back(line);
    if (line.empty() || line[0] == '#') continue;
    const size_t indent = line.find_first_not_of(' ');
    const size_t colon = line.find(':');
    const std::string key = line.substr(indent, colon - indent);
    stack.resize(indent / 2);
    std::string path;
    for (const std::string& s : stack) path += s + ".";
    path += key;
    const size_t value_start = line.find_first_not_of(' ', colon + 1);
    if (value_start == std::string::npos || line[value_start] == '#') {
      stack.push_back(key);  // a section
    } else {
      out.push_back({path, lines->size() - 1});
    }
  }
  return out;
}

TEST(PipelineConfig, DefaultsAreValid) { EXPECT_TRUE(PipelineConfig{}.validate().isOk()); }

TEST(PipelineConfig, DefaultsRoundTripExactly) {
  const std::string yaml = toYaml(PipelineConfig{});
  PipelineConfig parsed;
  parsed.seed = 99;  // must be overwritten by the text
  parsed.landmarks.tracker.gate_chi2 = 3.0;
  const Status s = parseConfigYaml(yaml, &parsed);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(toYaml(parsed), yaml);
  EXPECT_EQ(parsed.seed, PipelineConfig{}.seed);
  EXPECT_EQ(parsed.landmarks.tracker.gate_chi2, PipelineConfig{}.landmarks.tracker.gate_chi2);
  EXPECT_EQ(parsed.landmarks.inlier_ratio.converged_sigma_fraction,
            1.0 / 200.0);  // not a short decimal
  EXPECT_EQ(parsed.frontend.harris.k, 0.04f);
}

TEST(PipelineConfig, AwkwardValuesRoundTripBitForBit) {
  PipelineConfig c;
  c.frontend.harris.k = std::nextafter(0.04f, 1.0f);
  c.frontend.harris.initial_threshold = 123456789.0f;
  c.frontend.simd = frontend::Simd::kScalar;
  c.frontend.harris.bucketing = true;
  c.frontend.sad.cost_ratio = 1.0f / 3.0f + 1.0f;
  c.frontend.source = frontend::HypothesisSource::kCornerPairing;
  c.landmarks.policy = landmarks::Policy::kInlierRatio;
  c.landmarks.tracker.gate_chi2 = 0.1 + 0.2;
  c.landmarks.tracker.odometry_noise.rot_sigma_per_m = 1e-300;
  c.landmarks.consistency.contradiction_evidence = -0.0;
  c.landmarks.consistency.prior_real = std::nextafter(0.5, 1.0);
  c.landmarks.tracker.max_confirmed = 10'000'000;  // the upper bound
  c.landmarks.refine.enabled = false;
  c.mapping.resolution_m = 1.0 / 3.0;
  c.mapping.insert_free_space = false;
  c.seed = std::numeric_limits<uint64_t>::max();
  ASSERT_TRUE(c.validate().isOk()) << c.validate().message();

  PipelineConfig parsed;
  const Status s = parseConfigYaml(toYaml(c), &parsed);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(toYaml(parsed), toYaml(c));
  EXPECT_EQ(parsed.frontend.harris.k, c.frontend.harris.k);
  EXPECT_EQ(parsed.frontend.sad.cost_ratio, c.frontend.sad.cost_ratio);
  EXPECT_EQ(parsed.frontend.simd, frontend::Simd::kScalar);
  EXPECT_EQ(parsed.frontend.source, frontend::HypothesisSource::kCornerPairing);
  EXPECT_EQ(parsed.landmarks.policy, landmarks::Policy::kInlierRatio);
  EXPECT_EQ(parsed.landmarks.tracker.gate_chi2, 0.1 + 0.2);
  EXPECT_EQ(parsed.landmarks.tracker.odometry_noise.rot_sigma_per_m, 1e-300);
  EXPECT_TRUE(std::signbit(parsed.landmarks.consistency.contradiction_evidence));
  EXPECT_EQ(parsed.landmarks.consistency.prior_real, c.landmarks.consistency.prior_real);
  EXPECT_EQ(parsed.mapping.resolution_m, 1.0 / 3.0);
  EXPECT_EQ(parsed.seed, std::numeric_limits<uint64_t>::max());
}

TEST(PipelineConfig, WritesEveryFieldOnceWithAComment) {
  std::vector<std::string> lines;
  const std::vector<Leaf> all = leaves(toYaml(PipelineConfig{}), &lines);
  EXPECT_EQ(static_cast<int>(all.size()),
            kHarrisKeys + kSadKeys + kFrontendOwnKeys + kLandmarkKeys + kMappingKeys +
                kLocalizationKeys + kTopLevelKeys);
  int harris = 0;
  int sad = 0;
  int landmarks = 0;
  int mapping = 0;
  int localization = 0;
  for (const Leaf& leaf : all) {
    localization += leaf.path.rfind("localization.", 0) == 0;
    harris += leaf.path.rfind("frontend.harris.", 0) == 0;
    sad += leaf.path.rfind("frontend.sad.", 0) == 0;
    landmarks += leaf.path.rfind("landmarks.", 0) == 0;
    mapping += leaf.path.rfind("mapping.", 0) == 0;
    EXPECT_NE(lines[leaf.line].find(" # "), std::string::npos)
        << "no comment: " << lines[leaf.line];
  }
  EXPECT_EQ(harris, kHarrisKeys);
  EXPECT_EQ(sad, kSadKeys);
  EXPECT_EQ(landmarks, kLandmarkKeys);
  EXPECT_EQ(mapping, kMappingKeys);
  EXPECT_EQ(localization, kLocalizationKeys);
}

TEST(PipelineConfig, ReadsEveryKeyItWrites) {
  // Replacing any one value by a sequence must fail naming that key: proves the reader looks at
  // every key the writer emits, under the same path.
  std::vector<std::string> lines;
  const std::vector<Leaf> all = leaves(toYaml(PipelineConfig{}), &lines);
  for (const Leaf& leaf : all) {
    std::vector<std::string> edited = lines;
    std::string& line = edited[leaf.line];
    line = line.substr(0, line.find(':') + 1) + " [1, 2]";
    std::string text;
    for (const std::string& l : edited) text += l + "\n";
    SCOPED_TRACE(leaf.path);
    expectError(text, leaf.path + ": expected", "got a sequence");
  }
}

TEST(PipelineConfig, OverridesSingleValuesAndKeepsTheRest) {
  PipelineConfig start;
  start.landmarks.tracker.max_candidates = 777;  // not in the text: must survive
  PipelineConfig expected = start;
  expected.frontend.harris.k = 0.05f;
  expected.frontend.sad.window_width_px = 15;
  expected.frontend.source = frontend::HypothesisSource::kCornerPairing;
  expected.landmarks.tracker.gate_chi2 = 7.81;
  expected.landmarks.policy = landmarks::Policy::kWtaLrc;
  expected.mapping.resolution_m = 0.1;
  expected.mapping.insert_free_space = false;
  expected.seed = 42;

  PipelineConfig parsed = start;
  const Status s = parseConfigYaml(R"(
frontend:
  harris: {k: 0.05}
  sad:
    window_width_px: 15
  source: pairing
landmarks:
  tracker: {gate_chi2: 7.81}     # comments are fine
  policy: wta-lrc
mapping:
  resolution_m: 0.1
  insert_free_space: false
seed: 42
)",
                                   &parsed);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(toYaml(parsed), toYaml(expected));
  EXPECT_EQ(parsed.landmarks.tracker.max_candidates, 777);
}

// The flat landmarks section of before the groups: each old key names where it went.
TEST(PipelineConfig, OldFlatLandmarkKeysNameTheirNewPlace) {
  PipelineConfig config;
  Status s = parseConfigYaml("landmarks: {confirm_prob: 0.8}", &config);
  ASSERT_FALSE(s.isOk());
  EXPECT_EQ(s.message(),
            "landmarks.confirm_prob moved to landmarks.consistency.confirm_prob (line 1)");
  expectError("landmarks:\n  policy: culling\n  gate_chi2: 9\n",
              "landmarks.gate_chi2 moved to landmarks.tracker.gate_chi2",
              "(line 3)");
  expectError("landmarks: {odom_rot_sigma_per_m: 0}",
              "moved to landmarks.tracker.odometry_noise.rot_sigma_per_m");
  expectError("landmarks: {seen_count_min: 3}", "moved to landmarks.seen_count.min_observations");
  expectError("landmarks: {svo_min_inlier_ratio: 0.5}",
              "moved to landmarks.inlier_ratio.min_inlier_ratio");
  expectError("landmarks: {refine_huber: 2}", "moved to landmarks.refine.huber");
  // Removed keys say why.
  expectError("landmarks: {prior_real_lone: 0.9}", "landmarks.prior_real_lone was removed");
  expectError("landmarks: {max_disparity_px: 40}",
              "landmarks.max_disparity_px was removed",
              "frontend.sad.max_disparity_px");
  // The new places read.
  ASSERT_TRUE(parseConfigYaml("landmarks: {consistency: {confirm_prob: 0.8}, tracker: "
                              "{odometry_noise: {rot_sigma_per_m: 0}}, refine: {huber: 2}}",
                              &config)
                  .isOk());
  EXPECT_EQ(config.landmarks.consistency.confirm_prob, 0.8);
  EXPECT_EQ(config.landmarks.tracker.odometry_noise.rot_sigma_per_m, 0.0);
  EXPECT_EQ(config.landmarks.refine.huber, 2.0);
}

// Values an int can hold but the tracker cannot honour are refused with the key.
TEST(PipelineConfig, LandmarkOptionsHaveUpperBounds) {
  expectError("landmarks: {tracker: {max_candidates: 2147483647}}",
              "landmarks.tracker.max_candidates = 2147483647",
              "in [1, 10000000]");
  expectError("landmarks: {culling: {decision_frames: 2147483647}}",
              "landmarks.culling.decision_frames");
  expectError("landmarks: {tracker: {odometry_noise: {trans_sigma_per_sqrt_m: 1e300}}}",
              "landmarks.tracker.odometry_noise.trans_sigma_per_sqrt_m");
}

TEST(PipelineConfig, EachSectionAlone) {
  struct Case {
    const char* text;
    bool (*check)(const PipelineConfig&);
  };
  const Case cases[] = {
      {"frontend: {harris: {max_corners: 1500}}",
       [](const PipelineConfig& c) { return c.frontend.harris.max_corners == 1500; }},
      {"frontend: {sad: {zero_mean: true}}",
       [](const PipelineConfig& c) { return c.frontend.sad.zero_mean; }},
      {"frontend: {simd: scalar}",
       [](const PipelineConfig& c) { return c.frontend.simd == frontend::Simd::kScalar; }},
      {"landmarks: {consistency: {min_observations: 6}}",
       [](const PipelineConfig& c) { return c.landmarks.consistency.min_observations == 6; }},
      {"landmarks: {policy: seen-count}",
       [](const PipelineConfig& c) {
         return std::string(landmarks::policyName(c.landmarks.policy)) == "seen-count";
       }},
      {"mapping: {max_range_m: 4.5}",
       [](const PipelineConfig& c) { return c.mapping.max_range_m == 4.5; }},
      {"seed: 7", [](const PipelineConfig& c) { return c.seed == 7u; }},
      {"", [](const PipelineConfig& c) { return toYaml(c) == toYaml(PipelineConfig{}); }},
      {"# only a comment\n",
       [](const PipelineConfig& c) { return toYaml(c) == toYaml(PipelineConfig{}); }},
  };
  for (const Case& c : cases) {
    PipelineConfig config;
    const Status s = parseConfigYaml(c.text, &config);
    ASSERT_TRUE(s.isOk()) << c.text << ": " << s.message();
    EXPECT_TRUE(c.check(config)) << c.text;
  }
}

TEST(PipelineConfig, RejectsWrongTypes) {
  expectError("landmarks:\n  tracker:\n    gate_chi2: abc\n",
              "landmarks.tracker.gate_chi2",
              "expected a number, got \"abc\" (line 3)");
  expectError("frontend: {harris: {k: fast}}", "frontend.harris.k", "expected a number");
  expectError("frontend: {sad: {window_width_px: 2.5}}",
              "frontend.sad.window_width_px",
              "expected an integer, got \"2.5\"");
  expectError("landmarks: {consistency: {min_observations: 4.0}}",
              "landmarks.consistency.min_observations",
              "expected an integer");
  expectError("landmarks: {consistency: {min_observations: 1e3}}",
              "landmarks.consistency.min_observations",
              "expected an integer");
  expectError(
      "mapping: {insert_free_space: 2}", "mapping.insert_free_space", "expected true or false");
  expectError("frontend: {harris: {bucketing: maybe}}",
              "frontend.harris.bucketing",
              "expected true or false");
  expectError("seed: -1", "seed", "expected a non-negative integer");
  expectError("seed: 1.5", "seed", "expected a non-negative integer");
  expectError("seed: {a: 1}", "seed", "got a map");
  expectError(
      "landmarks: {tracker: {gate_chi2: [1, 2]}}", "landmarks.tracker.gate_chi2", "got a sequence");
}

TEST(PipelineConfig, RejectsNonFiniteAndOutOfRangeNumbers) {
  for (const char* v :
       {".nan", ".NaN", ".inf", "-.inf", "+.inf", "nan", "inf", "-inf", "infinity"}) {
    SCOPED_TRACE(v);
    expectError(std::string("landmarks: {tracker: {gate_chi2: ") + v + "}}",
                "landmarks.tracker.gate_chi2",
                "finite");
    expectError(std::string("frontend: {harris: {threshold_max: ") + v + "}}",
                "frontend.harris.threshold_max",
                "finite");
  }
  expectError(
      "landmarks: {tracker: {gate_chi2: 1e400}}", "landmarks.tracker.gate_chi2", "out of range");
  expectError(
      "frontend: {harris: {threshold_max: 1e39}}", "frontend.harris.threshold_max", "out of range");
  expectError("landmarks: {tracker: {max_confirmed: 10000000000}}",
              "landmarks.tracker.max_confirmed",
              "out of range");
  expectError("seed: 100000000000000000000", "seed", "out of range");
}

// Every frontend int option at INT_MAX is rejected by validate() with the key's full path (before
// the bounds, border_px and sad.lr_tolerance_px at INT_MAX ran into signed overflow, UBSan, and
// Release exited 0); the loader already rejects non-finite floats and out-of-range ints.
TEST(PipelineConfig, RejectsFrontendValuesBeyondWhatTheCodeHonours) {
  for (const char* key :
       {"border_px", "target_count", "max_corners", "grid_cols", "grid_rows", "max_per_cell"}) {
    SCOPED_TRACE(key);
    expectError(std::string("frontend: {harris: {") + key + ": 2147483647}}",
                std::string("frontend.harris.") + key + " = 2147483647");
  }
  for (const char* key : {"window_width_px",
                          "max_disparity_px",
                          "row_tolerance_px",
                          "max_hypotheses",
                          "min_separation_px",
                          "lr_tolerance_px",
                          "row_support_radius_px"}) {
    SCOPED_TRACE(key);
    expectError(std::string("frontend: {sad: {") + key + ": 2147483647}}",
                std::string("frontend.sad.") + key + " = 2147483647");
  }
  expectError("frontend: {sad: {min_disparity_px: 2147483646, max_disparity_px: 2147483647}}",
              "frontend.sad.min_disparity_px = 2147483646");
  for (const char* key : {"cost_ratio", "complete_cost_ratio", "max_cost_per_px"}) {
    SCOPED_TRACE(key);
    expectError(std::string("frontend: {sad: {") + key + ": .nan}}",
                std::string("frontend.sad.") + key,
                "finite");
  }
  expectError("frontend: {harris: {border_px: 32769}}", "frontend.harris.border_px", "32768");
  expectError("frontend: {sad: {lr_tolerance_px: 257}}", "frontend.sad.lr_tolerance_px", "256");
}

TEST(PipelineConfig, RejectsUnknownKeysWithASuggestion) {
  expectError("frontend:\n  harris:\n    treshold: 5\n",
              "unknown key frontend.harris.treshold (line 3)",
              "threshold_min");
  expectError("frontend: {harris: {borderpx: 5}}",
              "unknown key frontend.harris.borderpx",
              "did you mean border_px?");
  expectError("landmark: {gate_chi2: 3}", "unknown key landmark", "did you mean landmarks?");
  expectError(
      "landmarks: {tracker: {gate_chi: 3}}", "unknown key landmarks.tracker.gate_chi", "gate_chi2");
  expectError(
      "mapping: {zzz: 1}", "unknown key mapping.zzz", "allowed keys in mapping: resolution_m");
  expectError("frontend: {polcy: wta-lrc}", "unknown key frontend.polcy");
}

TEST(PipelineConfig, RejectsBadSectionsAndDocuments) {
  expectError("landmarks: 5", "landmarks: expected a map", "got \"5\"");
  expectError("landmarks: [1, 2]", "landmarks: expected a map", "got a sequence");
  expectError("frontend: {harris: 3}", "frontend.harris: expected a map");
  expectError("- 1\n- 2\n", "the document: expected a map");
  expectError("just text", "the document: expected a map");
}

TEST(PipelineConfig, RejectsUnknownEnumNames) {
  expectError("landmarks: {policy: best}", "landmarks.policy", "consistency");
  expectError(
      "frontend: {source: sgm}", "frontend.source", "sad, pairing, support, ncc or maxtree");
  expectError("frontend: {simd: neon}", "frontend.simd", "avx2");
}

// The per-component SIMD switches became the one knob frontend.simd.
TEST(PipelineConfig, OldSimdKeysNameTheNewKey) {
  expectError("frontend: {harris: {use_avx2: false}}",
              "frontend.harris.use_avx2 was replaced by frontend.simd",
              "(line 1)");
  expectError("frontend:\n  sad:\n    kernel: scalar\n",
              "frontend.sad.kernel was replaced by frontend.simd",
              "(line 3)");
}

TEST(PipelineConfig, ReportsYamlSyntaxErrors) {
  expectError("landmarks: {gate_chi2: 3\nmapping: {}\n", "YAML syntax error", "line");
  expectError("landmarks:\n  gate_chi2: [1,\nseed: 2\n", "YAML syntax error", "line 3");
  expectError("mapping:\n", "no value");
}

TEST(PipelineConfig, ValidatesAfterParsing) {
  expectError(
      "landmarks: {tracker: {gate_chi2: -1}}", "landmarks.tracker.gate_chi2", "in (0, 1000]");
  expectError("frontend: {harris: {k: 0.3}}", "frontend.harris", "k = 0.3");
  expectError("frontend: {sad: {window_width_px: 12}}", "frontend.sad", "window_width_px = 12");
  expectError("mapping: {prob_hit: 1.5}", "mapping.prob_hit");
}

class PipelineConfigFile : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::makeTempDir("pipeline_config"); }
  std::string dir_;
};

TEST_F(PipelineConfigFile, LoadsAFile) {
  const std::string path = dir_ + "/run.yaml";
  writeFile(path, "landmarks:\n  policy: culling\nseed: 3\n");
  PipelineConfig config;
  const Status s = loadConfigFile(path, &config);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(config.landmarks.policy, landmarks::Policy::kCulling);
  EXPECT_EQ(config.seed, 3u);
}

TEST_F(PipelineConfigFile, ErrorsNameTheFile) {
  const std::string path = dir_ + "/config.yaml";
  PipelineConfig config;

  Status s = loadConfigFile(dir_ + "/absent.yaml", &config);
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find(dir_ + "/absent.yaml"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("no such file"), std::string::npos) << s.message();

  s = loadConfigFile(dir_, &config);
  ASSERT_FALSE(s.isOk());
  EXPECT_NE(s.message().find("directory"), std::string::npos) << s.message();

  writeFile(path, "landmarks:\n  tracker:\n    gate_chi2: abc\n");
  s = loadConfigFile(path, &config);
  ASSERT_FALSE(s.isOk());
  EXPECT_EQ(s.message(),
            path + ": landmarks.tracker.gate_chi2: expected a number, got \"abc\" (line 3)");

  writeFile(path, "landmarks: {tracker: {gate_chi2: -1}}\n");
  s = loadConfigFile(path, &config);
  ASSERT_FALSE(s.isOk());
  EXPECT_EQ(s.message().rfind(path + ": landmarks.tracker.gate_chi2", 0), 0u) << s.message();

  writeFile(path, "seed: [1,\n");
  s = loadConfigFile(path, &config);
  ASSERT_FALSE(s.isOk());
  EXPECT_EQ(s.message().rfind(path + ": YAML syntax error", 0), 0u) << s.message();

  EXPECT_EQ(toYaml(config), toYaml(PipelineConfig{}));
}

TEST(PipelineConfigDefaultFile, MatchesTheDefaults) {
  // configs/default.yaml is toYaml(PipelineConfig{}) verbatim. To regenerate it after changing
  // an option or comment: TWOCAM_REGENERATE_CONFIGS=1 ctest -R PipelineConfigDefaultFile
  const std::string path = test::sourceDir() + "/configs/default.yaml";
  const std::string expected = toYaml(PipelineConfig{});
  const char* regenerate = std::getenv("TWOCAM_REGENERATE_CONFIGS");
  if (regenerate != nullptr && std::string(regenerate) == "1") writeFile(path, expected);

  ASSERT_TRUE(fs::exists(path)) << path;
  PipelineConfig parsed;
  parsed.seed = 12345;
  parsed.landmarks.policy = landmarks::Policy::kCulling;
  const Status s = loadConfigFile(path, &parsed);
  ASSERT_TRUE(s.isOk()) << s.message();
  EXPECT_EQ(toYaml(parsed), expected) << path << " does not parse to the defaults";
  EXPECT_EQ(readFile(path), expected)
      << path
      << " is stale; regenerate: TWOCAM_REGENERATE_CONFIGS=1 ctest -R PipelineConfigDefaultFile";
}

TEST(PipelineConfigShippedFiles, KittiConfigScalesTheDefaultOdometryNoiseAndTheMap) {
  // configs/kitti.yaml: the default odometry noise model x3 (the synthetic KITTI odometry is the
  // office noise x3) and a map for landmarks 6-60 m away; everything else the defaults.
  const std::string path = test::sourceDir() + "/configs/kitti.yaml";
  PipelineConfig kitti;
  const Status s = loadConfigFile(path, &kitti);
  ASSERT_TRUE(s.isOk()) << s.message();
  ASSERT_TRUE(kitti.validate().isOk());
  const PipelineConfig defaults;
  const auto& k = kitti.landmarks.tracker.odometry_noise;
  const auto& d = defaults.landmarks.tracker.odometry_noise;
  constexpr double kScale = 3.0;
  constexpr double kTol = 1e-12;
  EXPECT_NEAR(k.trans_sigma_per_sqrt_m, kScale * d.trans_sigma_per_sqrt_m, kTol);
  EXPECT_NEAR(k.trans_scale_sigma, kScale * d.trans_scale_sigma, kTol);
  EXPECT_NEAR(k.rot_sigma_per_sqrt_rad, kScale * d.rot_sigma_per_sqrt_rad, kTol);
  EXPECT_NEAR(k.rot_scale_sigma, kScale * d.rot_scale_sigma, kTol);
  EXPECT_NEAR(k.rot_sigma_per_m, kScale * d.rot_sigma_per_m, kTol);
  EXPECT_GT(kitti.mapping.max_range_m, 30.0);
  // Nothing else differs from the defaults.
  PipelineConfig rest = kitti;
  rest.landmarks.tracker.odometry_noise = d;
  rest.mapping.resolution_m = defaults.mapping.resolution_m;
  rest.mapping.max_range_m = defaults.mapping.max_range_m;
  EXPECT_EQ(toYaml(rest), toYaml(defaults));
}

}  // namespace
}  // namespace twocam::pipeline
