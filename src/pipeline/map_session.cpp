#include "pipeline/map_session.h"

#include <filesystem>
#include <utility>
#include <vector>

#include "store/landmark_store.h"

namespace twocam::pipeline {

Status MapSessionOptions::validate() const {
  if (Status s = recorder.validate(); !s) return s;
  if (Status s = working_set.validate(); !s) return s;
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
  const auto fail = [&](const Status& s) {
    return Status::error("--map " + path + ": " + s.message());
  };
  if (options.working_set.enabled() && !options.localize_only)
    session->working_set_ = std::make_unique<WorkingSet>(options.working_set);
  if (options.localize_only) {
    if (Status s = MapRelocalizer::open(path, rig, options.relocalizer, &session->relocalizer_); !s)
      return fail(s);
    *out = std::move(session);
    return Status::ok();
  }
  // An existing map is looked at read only: one that holds landmarks is extended, and is not
  // written before the run is placed in it.
  std::error_code ec;
  if (std::filesystem::exists(path, ec)) {
    std::unique_ptr<store::LandmarkStore> st;
    store::StoreInfo info;
    if (Status s = store::LandmarkStore::open(path, store::OpenMode::kReadOnly, &st); !s)
      return fail(s);
    if (Status s = st->info(&info); !s) return fail(s);
    session->extending_ = info.landmark_count > 0;
  }
  if (session->extending_) {
    MapRelocalizerOptions ropt = options.relocalizer;
    ropt.restore_without_descriptor = true;
    if (Status s = MapRelocalizer::open(path, rig, ropt, &session->relocalizer_); !s)
      return fail(s);
    session->rig_text_ = rigText(rig);
    session->config_text_ = toYaml(config);
    session->log_path_ = log_path;
  } else if (Status s = MapRecorder::open(path,
                                          rigText(rig),
                                          toYaml(config),
                                          log_path,
                                          options.recorder,
                                          &session->recorder_);
             !s) {
    return fail(s);
  }
  *out = std::move(session);
  return Status::ok();
}

Status MapSession::addFrame(const RunFrame& frame) {
  robot_o_ = Eigen::Vector3d(frame.output.pose.x_m, frame.output.pose.y_m, 0.0);
  last_frame_ = frame.log.index;
  if (recorder_) {
    if (Status s = recorder_->addFrame(frame); !s) return Status::error("--map: " + s.message());
  }
  if (!relocalizer_) return Status::ok();
  const bool was_placed = relocalizer_->placed();
  if (Status s = relocalizer_->addFrame(frame); !s)
    return Status::error("relocalisation: " + s.message());
  if (!extending_ || was_placed || !relocalizer_->placed()) return Status::ok();
  // Placed in this frame: the map is written from here on.
  if (Status s = MapRecorder::extend(path_,
                                     rig_text_,
                                     config_text_,
                                     log_path_,
                                     relocalizer_->T_m_o(),
                                     frame.log.index,
                                     options_.recorder,
                                     &recorder_);
      !s)
    return Status::error("--map " + path_ + ": " + s.message());
  recorder_->setCommitObserver(on_commit_);
  if (Status s = recorder_->addFrame(frame); !s) return Status::error("--map: " + s.message());
  return Status::ok();
}

Status MapSession::betweenFrames(Pipeline* pipeline) {
  if (Status s = restoreFromRelocalizer(pipeline); !s) return s;
  // The working set is kept right after a commit: every row it releases is then in the map.
  if (working_set_ && recorder_ && recorder_->committed() && robot_o_) {
    if (Status s =
            working_set_->update(*robot_o_, last_frame_, recorder_.get(), pipeline, &paged_out_);
        !s)
      return Status::error("--map " + path_ + ": " + s.message());
  }
  return Status::ok();
}

Status MapSession::restoreFromRelocalizer(Pipeline* pipeline) {
  if (!relocalizer_ || !options_.restore_landmarks) return Status::ok();
  std::vector<uint64_t> map_ids;
  const std::vector<Eigen::Vector3d> p_o = relocalizer_->takeLandmarksToRestore(&map_ids);
  if (p_o.empty()) return Status::ok();
  const std::vector<uint64_t> tracker_ids = pipeline->restoreLandmarks(p_o);
  if (recorder_ && extending_) {
    if (Status s = recorder_->adoptRestored(tracker_ids, map_ids); !s)
      return Status::error("--map " + path_ + ": " + s.message());
  }
  return Status::ok();
}

Status MapSession::finish() {
  if (!recorder_) return Status::ok();
  if (Status s = recorder_->finish(); !s)
    return Status::error("--map " + path_ + ": " + s.message());
  return Status::ok();
}

void MapSession::setCommitObserver(MapCommitObserver observer) {
  on_commit_ = std::move(observer);
  if (recorder_) recorder_->setCommitObserver(on_commit_);
}

const RelocalizationReport* MapSession::relocalization() const {
  return relocalizer_ ? &relocalizer_->report() : nullptr;
}

std::string MapSession::summaryLine(int processed_frames) const {
  if (extending_ && !recorder_)
    return "map: not merged: the run was never placed in " + path_ + " (the map is unchanged)";
  if (!recorder_) return "";
  if (recorder_->extending()) {
    return "map: session " + std::to_string(recorder_->session()) + " added " +
           std::to_string(recorder_->landmarksWritten()) + " landmarks (ids from " +
           std::to_string(recorder_->firstNewId()) + "), saw " +
           std::to_string(recorder_->landmarksUpdated()) + " of the map's again (" +
           std::to_string(recorder_->landmarksMerged()) + " confirmations merged into them), " +
           std::to_string(recorder_->keyframesWritten()) + " poses in " + path_;
  }
  return "map: " + std::to_string(recorder_->landmarksWritten()) + " landmarks and " +
         std::to_string(processed_frames) + " poses in " + path_ + " (session " +
         std::to_string(recorder_->session()) + ")";
}

}  // namespace twocam::pipeline
