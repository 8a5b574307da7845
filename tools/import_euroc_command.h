#pragma once
/// `twocam import-euroc`: converts a EuRoC MAV stereo sequence (raw, distorted cam0/cam1 images)
/// into a TwoCam rawlog of rectified pairs. See docs/recorded_data.md.

#include <optional>
#include <string>

namespace twocam::tools {

struct ImportEurocArgs {
  /// EuRoC sequence folder containing mav0/, or the mav0 folder itself.
  std::string input_dir;
  /// Output rawlog path; the images go to "<stem>_Images/" next to it.
  std::string output_path;
  /// Import at most this many stereo pairs (the first ones); all when unset.
  std::optional<int> max_frames;
  bool quiet = false;
};

/// Runs `twocam import-euroc`. Returns the process exit code (0 ok, 1 error); an error is one
/// line "twocam import-euroc: error: ..." on stderr and leaves no log (an older log at the
/// output path is kept).
int runImportEuroc(const ImportEurocArgs& args);

}  // namespace twocam::tools
