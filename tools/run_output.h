#pragma once
/// Helpers of `twocam run` (tools/run_command.cpp) that are about files, not the run: the frame
/// count for the progress bar, writing the staged outputs, and the pictures.

#include <optional>
#include <string>

#include "common/status.h"
#include "eval/run_evaluator.h"
#include "io/run_writer.h"
#include "pipeline/run.h"

namespace twocam::tools {

/// Frames the run will read: the log's external left images (TwoCam's logs), capped by
/// max_frames; for the progress bar and the default sample frame only; 0 when unknown.
int framesToRun(const std::string& log_path, std::optional<int> max_frames);

/// Stages every output (text files, PNGs, map.bt, timing.json, metrics.json last) and commits
/// the folder. Errors name the file; the earlier folder is then untouched.
[[nodiscard]] Status writeRunOutputs(const eval::RunOutputs& outputs,
                                     const pipeline::Run& run,
                                     io::RunWriter* writer);

/// The files a run wrote, in order, for the CLI's last line: "metrics.json, timing.json, ...";
/// a folder's files as the folder ("sample_frame/").
std::string writtenFiles(const eval::RunOutputs& outputs, const pipeline::Run& run);

/// Runs scripts/plot_run.py on the output folder. Pictures are a convenience: failing to draw
/// them is a warning, the run's data are already written.
void drawPictures(const std::string& output_dir);

}  // namespace twocam::tools
