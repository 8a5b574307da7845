#pragma once
#include <optional>
#include <string>

namespace twocam::tools {

/// `twocam run LOG -o OUTDIR [--config CFG.yaml] [--policy NAME]`: frontend, landmark database
/// and occupancy map over a log; outputs and their formats in docs/run.md.
struct RunArgs {
  std::string log_path;
  std::string output_dir;
  /// YAML config (pipeline/config.h); defaults when absent.
  std::optional<std::string> config_path;
  /// Override the config's landmarks.policy / frontend.source when given.
  std::optional<std::string> policy;
  std::optional<std::string> source;
  /// Override the config's localization.mode: odometry | pnp | fused.
  std::optional<std::string> localization;
  /// World file for the map evaluation; default: "<log stem>.world.yaml" beside the log when it
  /// exists (written by `twocam simulate`).
  std::optional<std::string> world_path;
  std::optional<int> max_frames;
  /// Landmark store to record into (pipeline/map_recorder.h), created when missing.
  std::optional<std::string> map_path;
  /// With map_path: relocalise in the map and give the run's poses in its frame; the map is
  /// only read (pipeline/map_relocalizer.h).
  bool localize_only = false;
  /// With map_path: the tracker's bounded working set (pipeline/working_set.h): radius [m] and
  /// count cap; absent: everything stays in memory.
  std::optional<double> working_set_radius_m;
  std::optional<int> working_set_max;
  /// With map_path (recording): one line per committed store transaction, "session S frame F
  /// keyframes K", flushed to the file once the commit has returned (replaced at the start).
  std::optional<std::string> map_commit_log;
  /// Frame (counted from 0) drawn in sample_frame/; default: the middle of the log.
  std::optional<int> sample_frame;
  /// Do not call scripts/plot_run.py at the end.
  bool no_pictures = false;
  bool quiet = false;
};

int runRun(const RunArgs& args);

}  // namespace twocam::tools
