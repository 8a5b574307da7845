/// twocam: the command-line program. Thin: parses arguments and calls library code.

#include <iostream>

#include <CLI/CLI.hpp>

#include "simulate_command.h"

int main(int argc, char** argv) {
  CLI::App app{"TwoCam: stereo landmark mapping for mobile robots (simulator, frontend, landmarks, mapping)"};
  app.require_subcommand(1);

  twocam::tools::SimulateArgs sim;
  int sim_frames = 0;
  uint64_t sim_seed = 0;
  auto* simulate = app.add_subcommand("simulate", "Render a world into an MRPT rawlog of stereo frames, wheel odometry and ground truth");
  simulate->add_option("world", sim.world_path, "World file (YAML, see worlds/README.md)")->required();
  simulate->add_option("-o,--output", sim.output_path, "Output rawlog path (external images go to <stem>_Images/)")->required();
  auto* frames_opt = simulate->add_option("--frames", sim_frames, "Number of frames (default: the world's 'frames')");
  auto* seed_opt = simulate->add_option("--seed", sim_seed, "Seed of all random draws (default: the world's 'seed')");
  simulate->add_option("--preview-dir", sim.preview_dir, "Folder for contact sheet, trajectory CSV and timing (default <stem>_preview)");
  simulate->add_flag("-q,--quiet", sim.quiet, "No progress bar");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (simulate->parsed()) {
      if (frames_opt->count() > 0) sim.frames = sim_frames;
      if (seed_opt->count() > 0) sim.seed = sim_seed;
      return twocam::tools::runSimulate(sim);
    }
  } catch (const std::exception& e) {
    std::cerr << "twocam: error: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
