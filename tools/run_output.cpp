#include "run_output.h"

#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <vector>

#include "io/rawlog.h"

extern char** environ;

namespace twocam::tools {

namespace fs = std::filesystem;

int framesToRun(const std::string& log_path, std::optional<int> max_frames) {
  std::error_code ec;
  const fs::path dir = io::imagesDirectoryFor(log_path);
  int n = 0;
  if (fs::is_directory(dir, ec)) {
    for (const auto& e : fs::directory_iterator(dir, ec)) {
      if (e.path().filename().string().rfind("left_", 0) == 0) ++n;
    }
  }
  if (!max_frames) return n;
  return n > 0 ? std::min(*max_frames, n) : *max_frames;
}

std::string writtenFiles(const eval::RunOutputs& outputs, const pipeline::Run& run) {
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
  return written;
}

Status writeRunOutputs(const eval::RunOutputs& outputs,
                       const pipeline::Run& run,
                       io::RunWriter* writer) {
  for (const auto& [name, content] : outputs.text_files) {
    if (Status s = writer->writeFile(name, content); !s) return s;
  }
  for (const eval::RunOutputs::Png& png : outputs.pngs) {
    if (Status s = writer->writePng(png.path, png.image); !s) return s;
  }
  if (run.summary().odometry_mode) {
    if (Status s = run.pipeline().mapper().writeBinary(writer->stagedPath("map.bt")); !s) return s;
  }
  if (Status s = writer->writeJson("timing.json", outputs.timing, 6); !s) return s;
  if (Status s = writer->writeJson("metrics.json", outputs.metrics, io::kMetricsJsonDigits); !s)
    return s;
  return writer->commit();
}

void drawPictures(const std::string& output_dir) {
  const auto warn = [](const std::string& m) {
    std::cerr << "twocam run: warning: " << m << std::endl;
  };
  std::string script = std::string(TWOCAM_SOURCE_DIR) + "/scripts/plot_run.py";
  if (const char* s = std::getenv("TWOCAM_PLOT_RUN")) script = s;
  std::error_code ec;
  if (!fs::exists(script, ec)) {
    warn("no pictures: " + script + " not found");
    return;
  }
  // Debian's interpreter, which has python3-matplotlib (a python3 earlier on PATH may not).
  const std::string python = fs::exists("/usr/bin/python3", ec) ? "/usr/bin/python3" : "python3";
  std::vector<std::string> argv_s = {python, script, output_dir};
  std::vector<char*> argv;
  for (std::string& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawnp(&pid, python.c_str(), nullptr, nullptr, argv.data(), environ) != 0) {
    warn("no pictures: cannot start python3");
    return;
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    warn("scripts/plot_run.py failed; the data files are complete");
}

}  // namespace twocam::tools
