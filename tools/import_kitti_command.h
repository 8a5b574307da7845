#pragma once
/// `twocam import-kitti`: converts a KITTI odometry sequence (rectified grey pairs, calib.txt,
/// optional poses.txt and times.txt) into a TwoCam rawlog with ground truth, and optionally
/// synthetic wheel odometry drawn from the ground truth. See docs/recorded_data.md.

#include <cstdint>
#include <optional>
#include <string>

namespace twocam::tools {

struct ImportKittiArgs {
  /// Seed of the synthetic odometry when --seed is not given.
  static constexpr uint64_t kDefaultSeed = 1;

  /// KITTI sequence folder (image_0|image_l, image_1|image_r, calib.txt, ...).
  std::string input_dir;
  /// Output rawlog path; the images go to "<stem>_Images/" next to it.
  std::string output_path;
  /// Noise file with an `odometry_noise:` section (as in a world file); when set, the log gets
  /// wheel odometry drawn from the ground-truth increments with that model, marked synthetic.
  std::optional<std::string> synthetic_odometry;
  /// Seed of the synthetic odometry's draws (only with synthetic_odometry; an error without
  /// it, since it would change nothing). Unset: kDefaultSeed.
  std::optional<uint64_t> seed;
  /// Import at most this many stereo pairs (the first ones); all when unset.
  std::optional<int> max_frames;
  bool quiet = false;
};

/// Runs `twocam import-kitti`. Returns the process exit code (0 ok, 1 error); an error is one
/// line "twocam import-kitti: error: ..." on stderr and leaves no log (an older log at the
/// output path is kept).
int runImportKitti(const ImportKittiArgs& args);

}  // namespace twocam::tools
