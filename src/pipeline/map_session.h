#pragma once
/// The run's landmark map (`twocam run --map MAP.db`), one object for the run loop's callbacks:
/// - a new or empty map is recorded into from the first frame (MapRecorder::open);
/// - a map that holds landmarks is extended: the run is relocalised in it first (MapRelocalizer,
///   read only), and once placed the map's landmarks join the run's tracker and the run is
///   recorded as a new session in the map frame (MapRecorder::extend, adoptRestored); a run that
///   is never placed writes nothing (merged() false, the file as it was);
/// - with `--localize-only` the map is only read: relocalised in, its landmarks handed to the
///   tracker, never written.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.h"
#include "common/status.h"
#include "pipeline/config.h"
#include "pipeline/map_recorder.h"
#include "pipeline/map_relocalizer.h"
#include "pipeline/run.h"
#include "pipeline/working_set.h"

namespace twocam::pipeline {

struct MapSessionOptions {
  /// Only read the map: relocalise in it and give the run's poses in its frame.
  bool localize_only = false;
  /// After relocalisation the map's landmarks join the run's tracker (Pipeline::restoreLandmarks);
  /// false keeps the run on its own landmarks (the comparison in docs/relocalization.md).
  bool restore_landmarks = true;
  MapRecorderOptions recorder;
  MapRelocalizerOptions relocalizer;
  /// The tracker's bounded working set while the run writes the map (not with localize_only).
  WorkingSetOptions working_set;
  [[nodiscard]] Status validate() const;
};

class MapSession {
 public:
  /// Opens the map at `path` before any frame is processed; refusals leave the file as it was
  /// (MapRecorder::open, MapRelocalizer::open). An existing map is opened read only until the
  /// run is placed in it. Errors start with "--map PATH: ".
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
  /// Told of every store transaction the run commits (MapRecorder::setCommitObserver), from the
  /// recorder of a new map and from the one an extended map gets once the run is placed.
  void setCommitObserver(MapCommitObserver observer);

  /// The landmarks the working set paged out of the tracker since the last call (copies of
  /// their last records, for evaluation); empty without a working set.
  std::vector<landmarks::Landmark> takePagedOut() { return std::move(paged_out_); }
  /// The working set's record, nullptr when it is off.
  [[nodiscard]] const WorkingSetStats* workingSet() const {
    return working_set_ ? &working_set_->stats() : nullptr;
  }

  [[nodiscard]] const std::string& path() const { return path_; }
  /// The recorder writing the map, nullptr before an extended map's run is placed and with
  /// --localize-only.
  [[nodiscard]] const MapRecorder* recorder() const { return recorder_.get(); }
  /// The relocalisation's report (--localize-only, or extending a map), nullptr otherwise.
  [[nodiscard]] const RelocalizationReport* relocalization() const;
  /// Extending a map that holds landmarks (not --localize-only).
  [[nodiscard]] bool extending() const { return extending_; }
  /// False when extending and the run was never placed: nothing of it went into the map.
  [[nodiscard]] bool merged() const { return !extending_ || recorder_ != nullptr; }
  /// One line for the run's summary: what the run wrote into the map (recording or extending),
  /// empty with --localize-only.
  [[nodiscard]] std::string summaryLine(int processed_frames) const;

 private:
  MapSession() = default;
  /// Once placed: the map's landmarks the relocaliser hands over join the tracker.
  Status restoreFromRelocalizer(Pipeline* pipeline);

  std::string path_;
  MapSessionOptions options_;
  bool extending_ = false;
  // Extending: the session's record, written once the run is placed.
  std::string rig_text_, config_text_, log_path_;
  std::unique_ptr<MapRecorder> recorder_;
  std::unique_ptr<MapRelocalizer> relocalizer_;
  std::unique_ptr<WorkingSet> working_set_;
  std::vector<landmarks::Landmark> paged_out_;
  /// The last frame's body position in the run's world frame.
  std::optional<Eigen::Vector3d> robot_o_;
  int32_t last_frame_ = -1;
  MapCommitObserver on_commit_;
};

}  // namespace twocam::pipeline
