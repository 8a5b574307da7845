#pragma once
/// The configuration file of `twocam run --config CFG.yaml`: every option of the frontend, the
/// landmark database and the occupancy mapper in one YAML document, plus the run's seed. Layout,
/// error messages and an example: docs/config.md; the defaults as a file: configs/default.yaml.
///
///   frontend:   {harris: {...HarrisOptions}, sad: {...SalientSadOptions}, source: sad}
///   landmarks:  {policy: consistency, tracker: {..., odometry_noise: {...}}, refine: {...},
///                consistency: {...}, seen_count: {...}, culling: {...}, inlier_ratio: {...}}
///   mapping:    {...MappingOptions}
///   localization: {mode: odometry, update: {...}, slip: {...}, pnp: {...}}
///   seed:       1
///
/// Keys are the C++ field names; enums are written as their command-line names. Every key is
/// optional (absent keys keep the value the config already had, normally the default); unknown
/// keys, wrong types and non-finite numbers are errors that name the key path and line.

#include <cstdint>
#include <string>

#include "common/status.h"
#include "frontend/frontend.h"
#include "landmarks/options.h"
#include "localization/options.h"
#include "mapping/options.h"

namespace twocam::pipeline {

/// The frontend options `twocam run` starts from: the frontend's own defaults except for the
/// corner budget. The landmark database confirms far more real points from a larger corner set:
/// on the office world (noise x1) 2500 corners per frame instead of 1000 gave 11 838 correct
/// confirmed landmarks instead of 3574 and precision 99.58 % instead of 98.89 %, because weak
/// corners are re-detected from frame to frame far more often when the threshold sits lower
/// (docs/landmarks.md, "Corner budget"). The cost is per-frame time (measured in pipeline_bench).
/// The frontend's standalone default (HarrisOptions, 1000) stays what its stereo evaluation and
/// benchmarks were measured with.
frontend::FrontendOptions pipelineFrontendDefaults();

struct PipelineConfig {
  /// Harris detection, 1-D SAD matching and the hypothesis source (pipelineFrontendDefaults()).
  frontend::FrontendOptions frontend = pipelineFrontendDefaults();
  /// Landmark database: policy, tracker (noise model, gates, life cycle), refinement and each
  /// policy's group. The tracker's disparity range is not a key: clampToRig sets it from the
  /// frontend's SAD range (after clamping that to the image width). A key of the flat layout
  /// before the groups ("landmarks.confirm_prob") is an error naming its new place.
  landmarks::LandmarkOptions landmarks;
  /// OctoMap occupancy mapping from confirmed landmarks.
  mapping::MappingOptions mapping;
  /// Where the poses come from (odometry, pnp, fused) and the pose update's options
  /// (docs/localization.md). The odometry noise model is the tracker's.
  localization::LocalizationOptions localization;
  /// Seed of the run's random draws [-], recorded (in config_used.yaml) for reproducibility.
  /// Today nothing in `twocam run` draws random numbers: Harris detection, SAD matching and the
  /// landmark database are deterministic and the Ceres refinement runs single-threaded, so one
  /// log and one config always give the same output whatever the seed. The seed is here so that
  /// a randomised component added later takes its streams from it (common/random.h makeRng)
  /// and the recorded config still describes the run completely. It does not seed simulation:
  /// `twocam simulate` takes its seed from the world file or --seed.
  uint64_t seed = 1;

  /// Calls each section's validate(); the message names the section, e.g.
  /// "landmarks.tracker.gate_chi2 = -1; must be in (0, 1000]" or "frontend.harris: k = 0.3; must be
  /// in (0, 0.25)".
  [[nodiscard]] Status validate() const;
};

/// Overrides the fields of *config whose keys appear in `yaml_text`, then validates the result.
/// Start from PipelineConfig{} for "defaults plus file". Empty text (or only comments) changes
/// nothing. On error *config is left untouched and the message names the key path and line, e.g.
///   landmarks.tracker.gate_chi2: expected a number, got "abc" (line 12)
///   landmarks.confirm_prob moved to landmarks.consistency.confirm_prob (line 4)
///   unknown key frontend.harris.treshold (line 3); did you mean one of initial_threshold, ...?
///   YAML syntax error: line 2, column 1: flow sequence without a closing bracket
/// Not thread-safe with other C-stdio writers to stderr: MRPT reports YAML syntax errors only
/// there, so stderr is redirected for the duration of the parse.
Status parseConfigYaml(const std::string& yaml_text, PipelineConfig* config);

/// Reads the file at `path` and applies parseConfigYaml. Every error message starts with the
/// path ("configs/x.yaml: landmarks.tracker.gate_chi2: ..."); a missing, unreadable or directory
/// path is reported as such.
Status loadConfigFile(const std::string& path, PipelineConfig* config);

/// The complete effective config as YAML: every key of every section, in the struct order, each
/// with a comment giving its meaning and unit. Numbers are written in the shortest form that
/// reads back to the same bits, so parseConfigYaml(toYaml(c)) reproduces c exactly.
std::string toYaml(const PipelineConfig& config);

}  // namespace twocam::pipeline
