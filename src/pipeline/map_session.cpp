#include "pipeline/map_session.h"

namespace twocam::pipeline {

Status MapSessionOptions::validate() const {
  if (Status s = recorder.validate(); !s) return s;
  return relocalizer.validate();
}

Status MapSession::open(const std::string& path,
                        const StereoRig& rig,
                        const PipelineConfig& config,
                        const std::string& log_path,
                        const MapSessionOptions& options,
                        std::unique_ptr<MapSession>* out) {
  if (Status s = options.validate(); !s) return s;
  std::unique_ptr<MapSession> session(new MapSession());
  session->path_ = path;
  session->options_ = options;
  Status s = options.localize_only
                 ? MapRelocalizer::open(path, rig, options.relocalizer, &session->relocalizer_)
                 : MapRecorder::open(path,
                                     rigText(rig),
                                     toYaml(config),
                                     log_path,
                                     options.recorder,
                                     &session->recorder_);
  if (!s) return Status::error("--map " + path + ": " + s.message());
  *out = std::move(session);
  return Status::ok();
}

Status MapSession::addFrame(const RunFrame& frame) {
  if (recorder_) {
    if (Status s = recorder_->addFrame(frame); !s) return Status::error("--map: " + s.message());
  }
  if (relocalizer_) {
    if (Status s = relocalizer_->addFrame(frame); !s)
      return Status::error("relocalisation: " + s.message());
  }
  return Status::ok();
}

Status MapSession::betweenFrames(Pipeline* pipeline) {
  if (relocalizer_ && options_.restore_landmarks)
    pipeline->restoreLandmarks(relocalizer_->takeLandmarksToRestore());
  return Status::ok();
}

Status MapSession::finish() {
  if (!recorder_) return Status::ok();
  if (Status s = recorder_->finish(); !s)
    return Status::error("--map " + path_ + ": " + s.message());
  return Status::ok();
}

const RelocalizationReport* MapSession::relocalization() const {
  return relocalizer_ ? &relocalizer_->report() : nullptr;
}

std::string MapSession::summaryLine(int processed_frames) const {
  if (!recorder_) return "";
  return "map: " + std::to_string(recorder_->landmarksWritten()) + " landmarks and " +
         std::to_string(processed_frames) + " poses in " + path_ + " (session " +
         std::to_string(recorder_->session()) + ")";
}

}  // namespace twocam::pipeline
