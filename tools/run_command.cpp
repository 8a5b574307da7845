#include "run_command.h"

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>

#include "eval/run_evaluator.h"
#include "io/rawlog.h"
#include "io/run_writer.h"
#include "pipeline/map_recorder.h"
#include "pipeline/map_relocalizer.h"
#include "pipeline/run.h"
#include "progress.h"
#include "run_output.h"
#include "sim/world_io.h"
#include "simulate_command.h"

namespace twocam::tools {
namespace {

std::string formatNumber(const io::Json& value, int decimals) {
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(decimals);
  o << value.get<double>();
  return o.str();
}

int fail(const std::string& message) {
  std::cerr << "twocam run: error: " << message << std::endl;
  return 1;
}

void warn(const std::string& message) {
  std::cerr << "twocam run: warning: " << message << std::endl;
}

}  // namespace

int runRun(const RunArgs& args) {
  pipeline::PipelineConfig config;  // defaults, then the file, then the command line
  if (args.config_path) {
    if (Status s = pipeline::loadConfigFile(*args.config_path, &config); !s)
      return fail(s.message());
  }
  if (args.policy) {
    if (Status s = landmarks::parsePolicy(*args.policy, &config.landmarks.policy); !s)
      return fail(s.message());
  }
  if (args.source) {
    if (Status s = frontend::parseHypothesisSource(*args.source, &config.frontend.source); !s)
      return fail(s.message());
  }
  if (args.localization) {
    if (Status s = localization::parseMode(*args.localization, &config.localization.mode); !s)
      return fail("--localization " + *args.localization + ": " + s.message());
  }
  std::unique_ptr<io::RawlogReader> reader;
  if (Status s = io::RawlogReader::open(args.log_path, &reader); !s) return fail(s.message());
  if (Status s = pipeline::clampToRig(reader->rig(), &config); !s) return fail(s.message());

  // The world, for the map evaluation of simulated runs: --world, else the log's sidecar.
  eval::RunEvaluator::Inputs inputs{args.log_path, nullptr, "", 0};
  const std::string sidecar = worldSidecarPath(args.log_path);
  std::error_code ec;
  const std::string world_path =
      args.world_path ? *args.world_path : (std::filesystem::exists(sidecar, ec) ? sidecar : "");
  sim::World world;
  if (world_path.empty()) {
    inputs.world_absent = "no world file (no " + sidecar + " beside the log, no --world)";
  } else if (Status s = sim::loadWorld(world_path, &world); !s) {
    if (args.world_path) return fail(s.message());
    warn("no map evaluation: " + s.message());
    inputs.world_absent = s.message();
  } else {
    inputs.world = &world;
  }

  // The output folder: checked against the inputs and staged before any work (all or nothing).
  std::unique_ptr<io::RunWriter> writer;
  io::RunWriter::Options wopt;
  if (const char* f = std::getenv("TWOCAM_TEST_FAIL_WRITE")) wopt.fail_write_for_tests = f;
  const std::vector<std::string> input_paths = {args.log_path,
                                                io::imagesDirectoryFor(args.log_path),
                                                args.config_path.value_or(""),
                                                world_path};
  if (Status s = io::RunWriter::begin(args.output_dir, input_paths, wopt, &writer); !s)
    return fail(s.message());

  // The map store: opened (refusals leave the file as it was) before any frame is processed.
  // --localize-only reads it to relocalise in; otherwise the run is recorded into it.
  std::unique_ptr<pipeline::MapRecorder> map;
  std::unique_ptr<pipeline::MapRelocalizer> relocalizer;
  if (args.localize_only && !args.map_path) return fail("--localize-only needs --map MAP.db");
  if (args.map_path && args.localize_only) {
    if (Status s = pipeline::MapRelocalizer::open(
            *args.map_path, reader->rig(), pipeline::MapRelocalizerOptions(), &relocalizer);
        !s)
      return fail("--map " + *args.map_path + ": " + s.message());
  } else if (args.map_path) {
    if (Status s = pipeline::MapRecorder::open(*args.map_path,
                                               pipeline::rigText(reader->rig()),
                                               pipeline::toYaml(config),
                                               args.log_path,
                                               pipeline::MapRecorderOptions(),
                                               &map);
        !s)
      return fail("--map " + *args.map_path + ": " + s.message());
  }

  const int total = framesToRun(args.log_path, args.max_frames);
  inputs.sample_frame = args.sample_frame ? *args.sample_frame : std::max(0, total / 2);
  pipeline::Run run(reader->rig(), config);
  eval::RunEvaluator evaluator(reader->rig(), config, inputs);
  ProgressBar progress("run", total, !args.quiet && total > 0);
  const auto on_frame = [&](const pipeline::RunFrame& f) {
    if (map) {
      if (Status s = map->addFrame(f); !s) return Status::error("--map: " + s.message());
    }
    if (relocalizer) {
      if (Status s = relocalizer->addFrame(f); !s)
        return Status::error("relocalisation: " + s.message());
    }
    return evaluator.addFrame(f);
  };
  // After the placed frame, the map's landmarks join the tracker (MapRelocalizer).
  const bool restore = std::getenv("TWOCAM_NO_RESTORE") == nullptr;
  const auto between_frames = [&](pipeline::Pipeline* pipe) {
    if (relocalizer && restore) pipe->restoreLandmarks(relocalizer->takeLandmarksToRestore());
    return Status::ok();
  };
  pipeline::RunCallbacks callbacks{
      warn, on_frame, [&](int frames) { progress.update(frames); }, between_frames};
  if (Status s =
          run.execute(pipeline::frameSource(*reader), args.log_path, args.max_frames, callbacks);
      !s)
    return fail(s.message());
  if (map) {
    if (Status s = map->finish(); !s) return fail("--map " + *args.map_path + ": " + s.message());
  }

  eval::RunOutputs outputs;
  if (Status s = evaluator.finish(run, &outputs); !s) return fail(s.message());
  // Odometry that no wheel measured (`twocam import-kitti --synthetic-odometry`): say so in the
  // metrics and the summary, so that results on it are not mistaken for real odometry.
  const std::optional<std::string>& synthetic = reader->syntheticOdometry();
  outputs.metrics["odometry_synthetic"] = synthetic.has_value();
  if (synthetic) outputs.summary += "odometry: SYNTHETIC (" + *synthetic + ")\n";
  if (outputs.map_evaluated)
    outputs.text_files.emplace_back("world_outline.csv", worldOutlineCsv(world));
  if (relocalizer) {
    const pipeline::RelocalizationReport& rr = relocalizer->report();
    outputs.metrics["relocalization"] = eval::relocalizationJson(rr, evaluator.groundTruthTrack());
    if (!rr.map_track.empty()) {
      outputs.text_files.emplace_back(
          "trajectory_map.tum",
          io::toTum(rr.map_track, "the run's poses in the frame of " + *args.map_path));
    }
    const io::Json& j = outputs.metrics["relocalization"];
    outputs.summary +=
        rr.frame < 0
            ? "relocalisation: never placed in " + *args.map_path + " (" +
                  std::to_string(rr.attempts) + " frames tried)\n"
            : "relocalisation: frame " + std::to_string(rr.frame) + " placed in " + *args.map_path +
                  " (" + std::to_string(rr.inliers) + " inliers" +
                  (j["error_m"].is_number() ? ", error " + formatNumber(j["error_m"], 3) + " m " +
                                                  formatNumber(j["error_deg"], 2) + " deg"
                                            : std::string()) +
                  ")\n";
  }
  if (Status s = writeRunOutputs(outputs, run, writer.get()); !s) return fail(s.message());

  // Every file written, in order; a folder's files as the folder.
  std::string written = "metrics.json, timing.json";
  if (run.summary().odometry_mode) written += ", map.bt";
  std::string last_dir;
  for (const auto& [path, content] : outputs.text_files) {
    const std::string dir =
        path.find('/') == std::string::npos ? "" : path.substr(0, path.find('/'));
    if (!dir.empty() && dir == last_dir) continue;
    last_dir = dir;
    written += ", " + (dir.empty() ? path : dir + "/");
  }
  std::cout << outputs.summary << "wrote " << written << " in " << args.output_dir << std::endl;
  if (map) {
    std::cout << "map: " << map->landmarksWritten() << " landmarks and " << run.summary().processed
              << " poses in " << *args.map_path << " (session " << map->session() << ")"
              << std::endl;
  }
  if (!args.no_pictures) {
    std::cout << "pictures:" << std::endl;
    drawPictures(writer->outputDir());
  }
  return 0;
}

}  // namespace twocam::tools
