#pragma once
/// The run's landmark map (`twocam run --map MAP.db`): recorded into (MapRecorder), or, with
/// `--localize-only`, only read to relocalise in (MapRelocalizer), whose placed frame hands the
/// map's landmarks to the run's tracker. One object for the run loop's callbacks.

#include <cstdint>
#include <memory>
#include <string>

#include "common/rig.h"
#include "common/status.h"
#include "pipeline/config.h"
#include "pipeline/map_recorder.h"
#include "pipeline/map_relocalizer.h"
#include "pipeline/run.h"

namespace twocam::pipeline {

struct MapSessionOptions {
  /// Only read the map: relocalise in it and give the run's poses in its frame.
  bool localize_only = false;
  /// After relocalisation the map's landmarks join the run's tracker (Pipeline::restoreLandmarks);
  /// false keeps the run on its own landmarks (the comparison in docs/relocalization.md).
  bool restore_landmarks = true;
  MapRecorderOptions recorder;
  MapRelocalizerOptions relocalizer;
  [[nodiscard]] Status validate() const;
};

class MapSession {
 public:
  /// Opens the map at `path` before any frame is processed; refusals leave the file as it was
  /// (MapRecorder::open, MapRelocalizer::open). Errors start with "--map PATH: ".
  static Status open(const std::string& path,
                     const StereoRig& rig,
                     const PipelineConfig& config,
                     const std::string& log_path,
                     const MapSessionOptions& options,
                     std::unique_ptr<MapSession>* out);

  /// RunCallbacks::on_frame.
  [[nodiscard]] Status addFrame(const RunFrame& frame);
  /// RunCallbacks::between_frames.
  [[nodiscard]] Status betweenFrames(Pipeline* pipeline);
  /// Writes what the recorder still queues; once, after the run.
  [[nodiscard]] Status finish();

  [[nodiscard]] const std::string& path() const { return path_; }
  /// The relocalisation's report with --localize-only, nullptr otherwise.
  [[nodiscard]] const RelocalizationReport* relocalization() const;
  /// One line for the run's summary: what the map now holds (recording), empty otherwise.
  [[nodiscard]] std::string summaryLine(int processed_frames) const;

 private:
  MapSession() = default;

  std::string path_;
  MapSessionOptions options_;
  std::unique_ptr<MapRecorder> recorder_;
  std::unique_ptr<MapRelocalizer> relocalizer_;
};

}  // namespace twocam::pipeline
