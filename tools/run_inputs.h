#pragma once
/// Helpers of `twocam run` (tools/run_command.cpp) that turn its arguments into the run's
/// inputs: the configuration and the world for the map evaluation.

#include <functional>
#include <string>

#include "common/status.h"
#include "eval/run_evaluator.h"
#include "pipeline/config.h"
#include "run_command.h"
#include "sim/world.h"

namespace twocam::tools {

/// The run's configuration: the defaults, then --config, then --policy, --source and
/// --localization. Errors name the file or the flag.
[[nodiscard]] Status runConfig(const RunArgs& args, pipeline::PipelineConfig* config);

/// The world for the map evaluation of a simulated log: --world, else the log's sidecar
/// (sim::worldSidecarPath) when it exists. An unreadable --world is an error; an unreadable
/// sidecar is a warning. Without a world, inputs->world_absent says why (metrics.json
/// "octomap": {"absent": ...}); with one, inputs->world points at *world. *world_path is the file
/// read, empty when none.
[[nodiscard]] Status evaluationWorld(const RunArgs& args,
                                     const std::function<void(const std::string&)>& warn,
                                     sim::World* world,
                                     std::string* world_path,
                                     eval::RunEvaluator::Inputs* inputs);

}  // namespace twocam::tools
