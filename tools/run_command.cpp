#include "run_command.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>

#include "eval/map_session_outputs.h"
#include "eval/run_evaluator.h"
#include "io/rawlog.h"
#include "io/run_writer.h"
#include "pipeline/map_session.h"
#include "pipeline/run.h"
#include "progress.h"
#include "run_inputs.h"
#include "run_output.h"

namespace twocam::tools {
namespace {

int fail(const std::string& message) {
  std::cerr << "twocam run: error: " << message << std::endl;
  return 1;
}

void warn(const std::string& message) {
  std::cerr << "twocam run: warning: " << message << std::endl;
}

}  // namespace

int runRun(const RunArgs& args) {
  pipeline::PipelineConfig config;
  if (Status s = runConfig(args, &config); !s) return fail(s.message());
  std::unique_ptr<io::RawlogReader> reader;
  if (Status s = io::RawlogReader::open(args.log_path, &reader); !s) return fail(s.message());
  if (Status s = pipeline::clampToRig(reader->rig(), &config); !s) return fail(s.message());
  if (args.localize_only && !args.map_path) return fail("--localize-only needs --map MAP.db");
  if ((args.working_set_radius_m || args.working_set_max) && (!args.map_path || args.localize_only))
    return fail(
        "--working-set-radius and --working-set-max need --map MAP.db (not --localize-only)");
  if (args.map_commit_log && (!args.map_path || args.localize_only))
    return fail("--map-commit-log needs --map MAP.db without --localize-only");

  eval::RunEvaluator::Inputs inputs;
  inputs.log_path = args.log_path;
  inputs.synthetic_odometry = reader->syntheticOdometry();
  sim::World world;
  std::string world_path;
  if (Status s = evaluationWorld(args, warn, &world, &world_path, &inputs); !s)
    return fail(s.message());

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

  // The map: opened (refusals leave the file as it was) before any frame is processed.
  std::unique_ptr<pipeline::MapSession> map;
  if (args.map_path) {
    pipeline::MapSessionOptions mopt;
    mopt.localize_only = args.localize_only;
    mopt.restore_landmarks = std::getenv("TWOCAM_NO_RESTORE") == nullptr;
    mopt.working_set.radius_m = args.working_set_radius_m.value_or(0.0);
    mopt.working_set.max_landmarks = args.working_set_max.value_or(0);
    if (Status s = pipeline::MapSession::open(
            *args.map_path, reader->rig(), config, args.log_path, mopt, &map);
        !s)
      return fail(s.message());
  }
  // The commit log: a line per commit, flushed to the kernel before the run goes on, so a
  // process killed after the line has been written keeps both the commit and the line.
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> commit_log(nullptr, &std::fclose);
  if (args.map_commit_log) {
    commit_log.reset(std::fopen(args.map_commit_log->c_str(), "w"));
    if (!commit_log) {
      return fail("--map-commit-log " + *args.map_commit_log +
                  ": cannot write: " + std::strerror(errno));
    }
    map->setCommitObserver([log = commit_log.get()](const pipeline::MapCommit& c) {
      std::fprintf(log,
                   "session %d frame %d keyframes %lld\n",
                   c.session,
                   c.last_frame,
                   static_cast<long long>(c.keyframes));
      std::fflush(log);
    });
  }

  const int total = framesToRun(args.log_path, args.max_frames);
  inputs.sample_frame = args.sample_frame ? *args.sample_frame : std::max(0, total / 2);
  pipeline::Run run(reader->rig(), config);
  eval::RunEvaluator evaluator(reader->rig(), config, inputs);
  ProgressBar progress("run", total, !args.quiet && total > 0);
  pipeline::RunCallbacks callbacks{warn,
                                   [&](const pipeline::RunFrame& f) {
                                     if (map) {
                                       if (Status s = map->addFrame(f); !s) return s;
                                     }
                                     return evaluator.addFrame(f);
                                   },
                                   [&](int frames) { progress.update(frames); },
                                   [&](pipeline::Pipeline* pipe) {
                                     if (!map) return Status::ok();
                                     const Status s = map->betweenFrames(pipe);
                                     evaluator.addPagedOut(map->takePagedOut());
                                     return s;
                                   }};
  if (Status s =
          run.execute(pipeline::frameSource(*reader), args.log_path, args.max_frames, callbacks);
      !s)
    return fail(s.message());
  if (map) {
    if (Status s = map->finish(); !s) return fail(s.message());
  }

  eval::RunOutputs outputs;
  if (Status s = evaluator.finish(run, &outputs); !s) return fail(s.message());
  if (map)
    eval::addMapSessionOutputs(
        *map, evaluator.groundTruthTrack(), run.summary().processed, &outputs);
  if (Status s = writeRunOutputs(outputs, run, writer.get()); !s) return fail(s.message());
  std::cout << outputs.summary << "wrote " << writtenFiles(outputs, run) << " in "
            << args.output_dir << std::endl;
  if (!args.no_pictures) {
    std::cout << "pictures:" << std::endl;
    drawPictures(writer->outputDir());
  }
  if (map && !map->merged()) {
    std::cerr << "twocam run: " << args.log_path << " was never placed in the map "
              << *args.map_path << ": not merged, the map is unchanged" << std::endl;
    return 2;
  }
  return 0;
}

}  // namespace twocam::tools
