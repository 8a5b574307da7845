/// twocam: the command-line program. Thin: parses arguments and calls library code.

#include <CLI/CLI.hpp>
#include <iostream>

#include "import_euroc_command.h"
#include "import_kitti_command.h"
#include "map_command.h"
#include "run_command.h"
#include "simulate_command.h"
#include "stereo_eval_command.h"

int main(int argc, char** argv) {
  CLI::App app{
      "TwoCam: stereo landmark mapping for mobile robots (simulator, frontend, landmarks, "
      "mapping)"};
  app.require_subcommand(1);

  twocam::tools::SimulateArgs sim;
  int sim_frames = 0;
  uint64_t sim_seed = 0;
  auto* simulate = app.add_subcommand(
      "simulate",
      "Render a world into an MRPT rawlog of stereo frames, wheel odometry and ground truth");
  simulate->add_option("world", sim.world_path, "World file (YAML, see worlds/README.md)")
      ->required();
  simulate
      ->add_option("-o,--output",
                   sim.output_path,
                   "Output rawlog path (external images go to <stem>_Images/)")
      ->required();
  auto* frames_opt = simulate->add_option(
      "--frames", sim_frames, "Number of frames (default: the world's 'frames')");
  auto* seed_opt = simulate->add_option(
      "--seed", sim_seed, "Seed of all random draws (default: the world's 'seed')");
  double sim_noise_scale = 1.0;
  auto* noise_opt = simulate->add_option(
      "--odometry-noise-scale",
      sim_noise_scale,
      "Multiply the world's odometry noise (0 = exact odometry, 3 = three times the default)");
  uint64_t sim_noise_seed = 0;
  auto* noise_seed_opt = simulate->add_option(
      "--noise-seed",
      sim_noise_seed,
      "Seed of the image and odometry noise only; textures keep the world's seed (the same "
      "world, another log)");
  int sim_start_waypoint = 0;
  auto* start_waypoint_opt = simulate->add_option(
      "--start-waypoint",
      sim_start_waypoint,
      "Start at this waypoint of the world's path (0 = the first), heading for the next");
  simulate->add_option(
      "--preview-dir",
      sim.preview_dir,
      "Folder for contact sheet, trajectory CSV and timing (default <stem>_preview)");
  simulate->add_flag("-q,--quiet", sim.quiet, "No progress bar");

  twocam::tools::StereoEvalArgs se;
  double se_gt_invalid = 0.0;
  auto* stereo_eval = app.add_subcommand(
      "stereo-eval",
      "Evaluate 1-D SAD stereo on one rectified pair against ground-truth disparities");
  stereo_eval->add_option("--left", se.left_path, "Left image (8-bit grey or colour)")->required();
  stereo_eval->add_option("--right", se.right_path, "Right image")->required();
  stereo_eval
      ->add_option(
          "--gt",
          se.gt_path,
          "Ground-truth disparity of the left view: 8/16-bit PNG/PGM (value / scale) or PFM")
      ->required();
  stereo_eval->add_option("--gt-scale", se.gt_scale, "Disparity = stored value / scale (PFM: 1)")
      ->required();
  auto* gt_invalid_opt = stereo_eval->add_option(
      "--gt-invalid",
      se_gt_invalid,
      "Stored value meaning 'no ground truth' besides 0 for integer files (PFM: inf)");
  stereo_eval->add_option("--mask", se.mask_path, "Evaluate only pixels whose mask value is 255");
  stereo_eval->add_option("--border", se.border_px, "Ignore this many pixels at every image edge");
  stereo_eval->add_option("--max-disp", se.max_disp, "Largest disparity searched [px]")->required();
  stereo_eval
      ->add_option("--mode",
                   se.mode,
                   "dense (every pixel, with post-processing), salient (Harris corners, several "
                   "hypotheses) or sparse (--matcher maxtree: its node end points)")
      ->required();
  stereo_eval->add_option(
      "--fill",
      se.fill,
      "--matcher support, dense: hole filling none|linear|farther (default farther)");
  stereo_eval->add_option("-o,--output", se.output_json, "Write the metrics as JSON");
  stereo_eval->add_option(
      "--image", se.output_image, "Write a picture of disparities and errors (PNG)");
  stereo_eval->add_option(
      "--window", se.window_px, "Window width [px] (default: dense 7, salient 11; support 13x13)");
  stereo_eval->add_flag("--exclude-occluded",
                        se.exclude_occluded,
                        "Evaluate only pixels the right camera sees (occlusion derived from the "
                        "ground truth; for sets without nonocc masks)");
  stereo_eval->add_flag("--birchfield-tomasi",
                        se.birchfield_tomasi,
                        "Salient mode: Birchfield-Tomasi sampling-insensitive cost instead of SAD");
  stereo_eval->add_option("--matcher",
                          se.matcher,
                          "sad (1-D SAD, default), support (support value), ncc (scaled-window "
                          "NCC, Bradley 2008), maxtree (1-D Max-Trees; --mode dense = "
                          "semi-dense, sparse = node end points, salient = nodes at corners), or "
                          "the dense references opencv-bm / opencv-sgbm");
  auto* post_opt = stereo_eval->add_option(
      "--post", se.post, "Dense post-processing steps in order, e.g. lrc,prop,median or none");
  stereo_eval->add_option("--scale-image",
                          se.scale_image,
                          "--matcher ncc: picture of the winning window scale (red 1/sqrt2, "
                          "green 1, blue sqrt2) (PNG)");

  twocam::tools::RunArgs run;
  int run_frames = 0, run_sample = 0;
  std::string run_policy, run_source, run_config, run_world, run_localization, run_map;
  auto* run_cmd =
      app.add_subcommand("run",
                         "Run frontend, landmark database and occupancy map over a log; write "
                         "metrics, landmarks, trajectories, map.bt and pictures");
  run_cmd
      ->add_option("log",
                   run.log_path,
                   "Input rawlog (TwoCam's own or any MRPT rawlog with stereo images; odometry "
                   "when present)")
      ->required();
  run_cmd
      ->add_option("-o,--output",
                   run.output_dir,
                   "Output folder (created; files in it are replaced only by complete new ones)")
      ->required();
  auto* run_config_opt = run_cmd->add_option(
      "--config", run_config, "YAML config (docs/config.md; defaults: configs/default.yaml)");
  auto* run_policy_opt =
      run_cmd->add_option("--policy",
                          run_policy,
                          "Landmark confidence policy, overrides the config: consistency "
                          "(default), wta-lrc, seen-count, culling, inlier-ratio");
  auto* run_source_opt =
      run_cmd->add_option("--source",
                          run_source,
                          "Hypothesis source, overrides the config: sad (default), pairing (Paper "
                          "A), support, ncc or maxtree (docs/matchers/)");
  auto* run_localization_opt = run_cmd->add_option(
      "--localization",
      run_localization,
      "Where the poses come from, overrides the config: odometry (default), pnp (OpenCV "
      "solvePnPRansac on the confirmed landmarks) or fused (odometry corrected by them)");
  auto* run_world_opt =
      run_cmd->add_option("--world",
                          run_world,
                          "World file for the map evaluation (default: <log stem>.world.yaml "
                          "beside the log, written by simulate)");
  auto* run_frames_opt =
      run_cmd->add_option("--frames", run_frames, "Process at most this many frames");
  auto* run_sample_opt =
      run_cmd->add_option("--sample-frame",
                          run_sample,
                          "Frame drawn in sample_frame/ (default: the middle of the log)");
  auto* run_map_opt = run_cmd->add_option(
      "--map",
      run_map,
      "Landmark store (SQLite, docs/store.md) to record the confirmed landmarks and the poses "
      "in; created when missing. A map that holds landmarks is extended: the run is relocalised "
      "in it first and, once placed, recorded as a new session in its frame; a run never placed "
      "is not merged (exit status 2, the map unchanged)");
  run_cmd->add_flag("--localize-only",
                    run.localize_only,
                    "With --map: relocalise in the map (read only) and write the run's poses in "
                    "its frame (trajectory_map.tum, metrics.json relocalization)");
  double run_ws_radius = 0.0;
  int run_ws_max = 0;
  auto* run_ws_radius_opt = run_cmd->add_option(
      "--working-set-radius",
      run_ws_radius,
      "With --map: confirmed landmarks farther than this from the robot [m] leave the tracker "
      "for the map and come back from it when the robot nears them (docs/store.md#working-set)");
  auto* run_ws_max_opt = run_cmd->add_option(
      "--working-set-max",
      run_ws_max,
      "With --map: at most this many of the map's confirmed landmarks in the tracker, the "
      "nearest (docs/store.md#working-set)");
  std::string run_commit_log;
  auto* run_commit_log_opt = run_cmd->add_option(
      "--map-commit-log",
      run_commit_log,
      "With --map: write one line 'session S frame F keyframes K' to this file (replaced) after "
      "each store transaction has committed, flushed at once: every frame of session S up to F "
      "is then in the map, even if the run is killed (crash trials, docs/store.md)");
  run_cmd->add_flag(
      "--no-pictures", run.no_pictures, "Do not draw the pictures (scripts/plot_run.py)");
  run_cmd->add_flag("-q,--quiet", run.quiet, "No progress bar");

  twocam::tools::ImportEurocArgs ie;
  int ie_max_frames = 0;
  auto* import_euroc = app.add_subcommand(
      "import-euroc",
      "Rectify a EuRoC MAV stereo sequence (mav0/cam0, cam1) into a TwoCam rawlog (no odometry)");
  import_euroc
      ->add_option("dir", ie.input_dir, "EuRoC sequence folder containing mav0/ (or mav0 itself)")
      ->required();
  import_euroc
      ->add_option("-o,--output",
                   ie.output_path,
                   "Output rawlog path (rectified images go to <stem>_Images/)")
      ->required();
  auto* ie_max_frames_opt = import_euroc->add_option(
      "--max-frames", ie_max_frames, "Import at most this many stereo pairs (the first ones)");
  import_euroc->add_flag("-q,--quiet", ie.quiet, "No progress bar");

  twocam::tools::ImportKittiArgs ik;
  int ik_max_frames = 0;
  uint64_t ik_seed = 0;
  std::string ik_noise;
  auto* import_kitti = app.add_subcommand(
      "import-kitti",
      "Convert a KITTI odometry sequence (image_0|image_l, image_1|image_r, calib.txt, poses.txt) "
      "into a TwoCam rawlog with ground truth; optionally synthetic wheel odometry");
  import_kitti
      ->add_option("dir", ik.input_dir, "KITTI sequence folder (images, calib.txt, poses.txt)")
      ->required();
  import_kitti
      ->add_option(
          "-o,--output", ik.output_path, "Output rawlog path (images go to <stem>_Images/)")
      ->required();
  auto* ik_noise_opt = import_kitti->add_option(
      "--synthetic-odometry",
      ik_noise,
      "Add wheel odometry drawn from the ground-truth increments with the odometry_noise: "
      "section of this YAML file (a world file's model; the log marks it synthetic)");
  auto* ik_seed_opt = import_kitti->add_option(
      "--seed", ik_seed, "Seed of the synthetic odometry's draws (default 1)");
  auto* ik_max_frames_opt = import_kitti->add_option(
      "--max-frames", ik_max_frames, "Import at most this many stereo pairs (the first ones)");
  import_kitti->add_flag("-q,--quiet", ik.quiet, "No progress bar");

  twocam::tools::MapArgs map_args;
  const twocam::tools::MapCommand map_cmd = twocam::tools::addMapCommand(app, &map_args);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (simulate->parsed()) {
      if (frames_opt->count() > 0) sim.frames = sim_frames;
      if (seed_opt->count() > 0) sim.seed = sim_seed;
      if (noise_opt->count() > 0) sim.odometry_noise_scale = sim_noise_scale;
      if (start_waypoint_opt->count() > 0) sim.start_waypoint = sim_start_waypoint;
      if (noise_seed_opt->count() > 0) sim.noise_seed = sim_noise_seed;
      return twocam::tools::runSimulate(sim);
    }
    if (import_euroc->parsed()) {
      if (ie_max_frames_opt->count() > 0) ie.max_frames = ie_max_frames;
      return twocam::tools::runImportEuroc(ie);
    }
    if (import_kitti->parsed()) {
      if (ik_max_frames_opt->count() > 0) ik.max_frames = ik_max_frames;
      if (ik_seed_opt->count() > 0) ik.seed = ik_seed;
      if (ik_noise_opt->count() > 0) ik.synthetic_odometry = ik_noise;
      return twocam::tools::runImportKitti(ik);
    }
    if (run_cmd->parsed()) {
      if (run_frames_opt->count() > 0) run.max_frames = run_frames;
      if (run_sample_opt->count() > 0) run.sample_frame = run_sample;
      if (run_config_opt->count() > 0) run.config_path = run_config;
      if (run_policy_opt->count() > 0) run.policy = run_policy;
      if (run_source_opt->count() > 0) run.source = run_source;
      if (run_localization_opt->count() > 0) run.localization = run_localization;
      if (run_world_opt->count() > 0) run.world_path = run_world;
      if (run_map_opt->count() > 0) run.map_path = run_map;
      if (run_ws_radius_opt->count() > 0) run.working_set_radius_m = run_ws_radius;
      if (run_ws_max_opt->count() > 0) run.working_set_max = run_ws_max;
      if (run_commit_log_opt->count() > 0) run.map_commit_log = run_commit_log;
      return twocam::tools::runRun(run);
    }
    if (map_cmd.map->parsed()) return twocam::tools::runMap(map_cmd, map_args);
    if (stereo_eval->parsed()) {
      if (gt_invalid_opt->count() > 0) se.gt_invalid = se_gt_invalid;
      se.post_given = post_opt->count() > 0;
      return twocam::tools::runStereoEval(se);
    }
  } catch (const std::exception& e) {
    std::cerr << "twocam: error: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
