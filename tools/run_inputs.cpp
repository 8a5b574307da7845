#include "run_inputs.h"

#include <filesystem>

#include "sim/slip_truth.h"
#include "sim/world_files.h"
#include "sim/world_io.h"

namespace twocam::tools {

Status runConfig(const RunArgs& args, pipeline::PipelineConfig* config) {
  *config = pipeline::PipelineConfig();
  if (args.config_path) {
    if (Status s = pipeline::loadConfigFile(*args.config_path, config); !s) return s;
  }
  if (args.policy) {
    if (Status s = landmarks::parsePolicy(*args.policy, &config->landmarks.policy); !s) return s;
  }
  if (args.source) {
    if (Status s = frontend::parseHypothesisSource(*args.source, &config->frontend.source); !s)
      return s;
  }
  if (args.localization) {
    if (Status s = localization::parseMode(*args.localization, &config->localization.mode); !s)
      return Status::error("--localization " + *args.localization + ": " + s.message());
  }
  return Status::ok();
}

Status evaluationWorld(const RunArgs& args,
                       const std::function<void(const std::string&)>& warn,
                       sim::World* world,
                       std::string* world_path,
                       eval::RunEvaluator::Inputs* inputs) {
  const std::string sidecar = sim::worldSidecarPath(args.log_path);
  std::error_code ec;
  *world_path =
      args.world_path ? *args.world_path : (std::filesystem::exists(sidecar, ec) ? sidecar : "");
  inputs->world = nullptr;
  if (world_path->empty()) {
    inputs->world_absent = "no world file (no " + sidecar + " beside the log, no --world)";
  } else if (Status s = sim::loadWorld(*world_path, world); !s) {
    if (args.world_path) return s;
    warn("no map evaluation: " + s.message());
    inputs->world_absent = s.message();
  } else {
    inputs->world = world;
  }
  // The true slips: the world's, else the sidecar of import-kitti --synthetic-odometry.
  const std::string slips_sidecar = sim::slipsSidecarPath(args.log_path);
  if (inputs->world) {
    inputs->true_slips =
        sim::slipsAtFrameRate(world->odometry_noise.slips, world->robot.frame_rate_hz);
    inputs->true_slips_source = *world_path;
  } else if (std::filesystem::exists(slips_sidecar, ec)) {
    std::vector<sim::TrueSlip> slips;
    if (Status s = sim::loadSlipsCsv(slips_sidecar, &slips); !s) {
      warn("no slip metrics: " + s.message());
      inputs->true_slips_absent = s.message();
    } else {
      inputs->true_slips = std::move(slips);
      inputs->true_slips_source = slips_sidecar;
    }
  } else {
    inputs->true_slips_absent = "no world file and no " + slips_sidecar +
                                " beside the log, so the true slip events are unknown";
  }
  return Status::ok();
}

}  // namespace twocam::tools
