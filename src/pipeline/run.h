#pragma once
/// One run of the pipeline over a stream of logged frames: the frame loop of `twocam run` and its
/// policies, apart from evaluation (eval/run_evaluator.h) and output (io/run_writer.h).
///
/// Policies:
/// - A log whose first frame has no odometry runs the frontend only (corners and hypotheses; no
///   landmarks, no map): the landmark database needs wheel odometry to predict where landmarks
///   reappear. Said once through RunCallbacks::warn.
/// - In odometry mode a later frame without odometry is skipped with a warning; so is a frame the
///   landmark database refuses (NaN pose, time going backwards), which leaves it unchanged.
///   Any other frame error (frontend: an image of the wrong size) stops the run.
/// - The first frame whose camera lies outside the map's extent is warned about (such frames are
///   not mapped; landmarks go on).
/// - Per processed frame: stage times and counts (FrameRecord), the odometry track.

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/rig.h"
#include "common/status.h"
#include "io/rawlog.h"
#include "io/trajectory.h"
#include "pipeline/config.h"
#include "pipeline/pipeline.h"

namespace twocam::pipeline {

/// A processed frame as observers see it; refers to the run's state, valid during the callback.
struct RunFrame {
  const io::LogFrame& log;  ///< images, odometry and ground truth as read
  const FrameOutput& output;
  const Pipeline& pipeline;
  bool odometry_mode = true;
};

/// Stage times and counts of one processed frame (timings.csv).
struct FrameRecord {
  int32_t frame = 0;
  StageTimes times;
  int64_t corners = 0;
  int64_t hypotheses = 0;
  int candidates = 0;  ///< in the database after the frame
  int confirmed = 0;
  int confirmations = 0;  ///< candidates confirmed in this frame
  int reassociated = 0;   ///< confirmed landmarks found by the second association pass
  int fused = 0;          ///< candidates fused into a confirmed landmark instead of confirmed
  int reclaimed = 0;      ///< corners taken by a confirmed landmark at seeding (not seeded)
};

struct RunSummary {
  int frames = 0;  ///< read from the log (up to max_frames)
  int processed = 0;
  int skipped = 0;
  bool odometry_mode = true;
  int frames_outside_map = 0;
  /// Sums over processed frames, for per-frame means.
  int64_t sum_corners = 0;
  int64_t sum_salient_points = 0;
  int64_t sum_hypotheses = 0;
  /// Per processed frame, unless RunOptions::keep_frame_records is false (then empty, as are
  /// the other per-frame vectors below).
  std::vector<FrameRecord> records;
  /// Odometry pose of each processed frame (odometry mode) in the odometry world frame.
  std::vector<io::TimedPose> odom_track;
  /// The pose each processed frame used (odometry mode: equals odom_track), the robot's world.
  std::vector<io::TimedPose> pose_track;
  /// Per processed frame (odometry mode): the pose used visual measurements; confirmed landmarks
  /// in the pose (inliers).
  std::vector<uint8_t> visual;
  std::vector<int> landmarks_used;
  /// Per processed frame (odometry mode): the confirmed landmarks' observations the pose was
  /// solved on (FrameOutput::landmarks_observed); landmarks_used of them were inliers.
  std::vector<int> landmarks_observed;
  /// Frames the slip test flagged as odometry outliers (fused), in order.
  std::vector<int32_t> slip_frames;
  /// Per processed frame (odometry mode): the slip search (FrameOutput::searched,
  /// search_accepted): 0 the prediction held (or no check), 1 searched, 2 the searched pose
  /// replaced the prediction.
  std::vector<uint8_t> search;
  /// Per processed frame (odometry mode): the slip search's figures (FrameOutput::search_*).
  struct SearchFigures {
    int reference = 0;
    int prediction_score = 0;
    double chance_score = 0.0;  ///< FrameOutput::search_chance_score
    int best_score = 0;
    int rival_score = 0;
    int best_reference = 0;          ///< FrameOutput::search_best_reference
    double best_chance_score = 0.0;  ///< FrameOutput::search_best_chance_score
    Pose2 correction;
    int reanchor_reference = 0;  ///< FrameOutput::reanchor_reference
    bool reanchored = false;     ///< FrameOutput::reanchored
  };
  std::vector<SearchFigures> search_figures;
  /// Time stamp of the first frame read [ns] (the simulator's time 0).
  int64_t first_t_ns = 0;
  /// Wall time of the whole loop, reading and callbacks included [ms].
  double wall_ms = 0.0;
};

struct RunCallbacks {
  /// One line per event (skipped frame, frontend-only mode, camera outside the map).
  std::function<void(const std::string&)> warn;
  /// After each processed frame; an error stops the run and is returned.
  std::function<Status(const RunFrame&)> on_frame;
  /// After each frame read, with the number read so far.
  std::function<void(int)> progress;
  /// After on_frame, before the next frame: may change the pipeline between frames (e.g. hand
  /// it a saved map's landmarks, Pipeline::restoreLandmarks). An error stops the run.
  std::function<Status(Pipeline*)> between_frames;
};

/// Reads the next frame into *frame; false at the end, with *status saying whether the end was
/// an error (io::RawlogReader::next).
using FrameSource = std::function<bool(io::LogFrame*, Status*)>;

struct RunOptions {
  /// Keep the per-frame vectors of RunSummary (records, tracks, visual, landmarks_used, search;
  /// evaluation and timings.csv read them). False for a run without end (a robot, the long-run
  /// benchmark): the summary keeps its counts and sums only and memory does not grow per frame.
  bool keep_frame_records = true;
};

class Run {
 public:
  /// `config` as for Pipeline (valid, fitted to the rig by clampToRig).
  Run(const StereoRig& rig, const PipelineConfig& config, const RunOptions& options = {});

  /// Runs the loop over `next` (at most max_frames frames when given). `source_name` (the log
  /// path) starts the errors about the stream as a whole. Errors: a read error, a frontend or
  /// callback error (prefixed "frame N: " for the frontend), no frame at all, no frame that
  /// could be processed.
  [[nodiscard]] Status execute(const FrameSource& next,
                               const std::string& source_name,
                               std::optional<int> max_frames,
                               const RunCallbacks& callbacks);

  [[nodiscard]] const Pipeline& pipeline() const { return pipe_; }
  [[nodiscard]] const RunSummary& summary() const { return summary_; }

 private:
  Pipeline pipe_;
  RunOptions options_;
  RunSummary summary_;
};

/// FrameSource over a rawlog reader (which must outlive it).
[[nodiscard]] FrameSource frameSource(io::RawlogReader& reader);

}  // namespace twocam::pipeline
