#pragma once
#include <cstdint>
#include <optional>
#include <string>

namespace twocam::sim {
struct World;
}

namespace twocam::tools {

struct SimulateArgs {
  std::string world_path;
  std::string output_path;
  std::optional<int> frames;
  std::optional<uint64_t> seed;
  /// Multiplies the world's odometry noise (sim::scaledOdometryNoise); 0 = exact odometry.
  std::optional<double> odometry_noise_scale;
  /// Waypoint the robot starts at, heading for the next (sim::RobotSpec::start_waypoint).
  std::optional<int> start_waypoint;
  /// Seed of the image and odometry noise only: the textures keep the world's seed (the same
  /// world seen again). Exclusive with seed.
  std::optional<uint64_t> noise_seed;
  /// Folder for the contact sheet, trajectory CSV and timing summary; default "<stem>_preview"
  /// next to the log.
  std::string preview_dir;
  bool quiet = false;
};

/// Runs `twocam simulate`. Returns the process exit code (0 ok, 1 error); errors go to stderr.
int runSimulate(const SimulateArgs& args);

}  // namespace twocam::tools
