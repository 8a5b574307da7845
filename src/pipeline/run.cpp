#include "pipeline/run.h"

#include <cmath>
#include <sstream>

#include "common/frames.h"
#include "common/timer.h"

namespace twocam::pipeline {
namespace {

/// A pose the landmark maths can take: finite, within io::kMaxLogCoordinateM of the origin.
bool finitePose(const Pose2& p) {
  return std::isfinite(p.x_m) && std::isfinite(p.y_m) && std::isfinite(p.yaw_rad) &&
         std::abs(p.x_m) <= io::kMaxLogCoordinateM && std::abs(p.y_m) <= io::kMaxLogCoordinateM;
}

}  // namespace

Run::Run(const StereoRig& rig, const PipelineConfig& config, const RunOptions& options)
    : pipe_(rig, config), options_(options) {}

FrameSource frameSource(io::RawlogReader& reader) {
  return [&reader](io::LogFrame* frame, Status* status) { return reader.next(frame, status); };
}

Status Run::execute(const FrameSource& next,
                    const std::string& source_name,
                    std::optional<int> max_frames,
                    const RunCallbacks& callbacks) {
  const auto warn = [&](const std::string& message) {
    if (callbacks.warn) callbacks.warn(message);
  };
  const Timer wall;
  RunSummary& s = summary_;
  s = RunSummary{};
  FrameOutput fo;
  io::LogFrame frame;
  Status read_status;
  while ((!max_frames || s.frames < *max_frames) && next(&frame, &read_status)) {
    if (s.frames == 0 && !frame.odometry) {
      s.odometry_mode = false;
      pipe_.skipRowSupport();
      warn(source_name +
           " has no odometry: running the frontend only (corners and hypotheses); the landmark "
           "database needs wheel odometry to predict where landmarks reappear, so there are no "
           "landmarks and no map");
    }
    if (s.frames == 0) s.first_t_ns = frame.stereo.t_ns;
    ++s.frames;
    if (callbacks.progress) callbacks.progress(s.frames);
    if (s.odometry_mode && !frame.odometry) {
      warn("skipping frame " + std::to_string(frame.index) + ": it has no odometry");
      ++s.skipped;
      continue;
    }
    if (s.odometry_mode && !finitePose(frame.odometry->pose)) {
      const Pose2& p = frame.odometry->pose;
      std::ostringstream os;
      os << "skipping frame " << frame.index << ": its odometry pose (" << p.x_m << ", " << p.y_m
         << ", " << p.yaw_rad << ") is not finite or beyond " << io::kMaxLogCoordinateM << " m";
      warn(os.str());
      ++s.skipped;
      continue;
    }
    const Status st = s.odometry_mode
                          ? pipe_.process(frame.index, frame.stereo, frame.odometry->pose, &fo)
                          : pipe_.processFrontendOnly(frame.stereo, &fo);
    if (!st) {
      if (fo.failure != FrameOutput::Failure::kLandmarks) {
        return Status::error("frame " + std::to_string(frame.index) + ": " + st.message());
      }
      // The database refused the frame (NaN pose, time going backwards): it is unchanged.
      warn("skipping " + st.message());
      ++s.skipped;
      continue;
    }
    ++s.processed;
    if (fo.outside_map && s.frames_outside_map++ == 0) {
      warn("frame " + std::to_string(frame.index) + ": the camera is outside the map's extent (" +
           std::to_string(fo.camera_origin_w.norm()) +
           " m from the origin); such frames are not mapped");
    }
    const int64_t corners = static_cast<int64_t>(pipe_.frontend().corners().size());
    const int64_t hypotheses = static_cast<int64_t>(pipe_.hypotheses().hypotheses.size());
    s.sum_corners += corners;
    s.sum_salient_points += static_cast<int64_t>(pipe_.hypotheses().points.size());
    s.sum_hypotheses += hypotheses;
    if (fo.slip_frame >= 0) s.slip_frames.push_back(fo.slip_frame);
    if (s.odometry_mode && options_.keep_frame_records) {
      s.odom_track.push_back({frame.stereo.t_ns, toIsometry(frame.odometry->pose)});
      s.pose_track.push_back({frame.stereo.t_ns, toIsometry(fo.pose)});
      s.visual.push_back(fo.visual ? 1 : 0);
      s.landmarks_used.push_back(fo.landmarks_used);
      s.landmarks_observed.push_back(fo.landmarks_observed);
      s.search.push_back(fo.search_accepted ? 2 : (fo.searched ? 1 : 0));
      s.search_figures.push_back({fo.search_reference,
                                  fo.search_prediction_score,
                                  fo.search_chance_score,
                                  fo.search_best_score,
                                  fo.search_rival_score,
                                  fo.search_best_reference,
                                  fo.search_best_chance_score,
                                  fo.search_correction,
                                  fo.reanchor_reference,
                                  fo.reanchored});
    }
    if (callbacks.on_frame) {
      if (Status cs = callbacks.on_frame(RunFrame{frame, fo, pipe_, s.odometry_mode}); !cs)
        return cs;
    }
    if (callbacks.between_frames) {
      if (Status cs = callbacks.between_frames(&pipe_); !cs) return cs;
    }
    if (!options_.keep_frame_records) continue;
    s.records.push_back({frame.index,
                         fo.times,
                         corners,
                         hypotheses,
                         pipe_.database().numCandidates(),
                         pipe_.database().numConfirmed(),
                         pipe_.report().confirmed,
                         pipe_.report().reassociated,
                         pipe_.report().fused,
                         pipe_.report().reclaimed});
  }
  s.wall_ms = wall.elapsedMs();
  if (!read_status) return read_status;
  if (s.frames == 0) return Status::error(source_name + ": no stereo frames");
  if (s.processed == 0) return Status::error(source_name + ": no frame could be processed");
  return Status::ok();
}

}  // namespace twocam::pipeline
