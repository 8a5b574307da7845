#pragma once
#include <optional>
#include <string>

namespace twocam::tools {

/// `twocam run LOG -o OUTDIR [--policy NAME]`: frontend and landmark database over a log.
struct RunArgs {
  std::string log_path;
  std::string output_dir;
  std::string policy = "consistency";
  std::string source = "sad";
  std::optional<int> max_frames;
  bool quiet = false;
};

int runRun(const RunArgs& args);

}  // namespace twocam::tools
