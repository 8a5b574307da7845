#pragma once
/// Evaluation and output schema of one `twocam run` (docs/run.md): fed frame by frame beside
/// pipeline::Run, it judges the frames against the log's ground truth (landmark_metrics.h),
/// measures the map the robot built against the world and builds the same map again with the
/// true poses (so that phantom voxels there measure wrong landmarks, not pose error) and with
/// the odometry poses, draws the sample frame, and at the end turns
/// everything into the run's files: landmarks.csv, metrics.json (as a JSON value), timings,
/// trajectories, voxel lists, and the summary lines printed by the CLI.
///
/// Ground truth counts only while every processed frame has it (a depth image of the frame's
/// size and a true pose): the first frame without it ends the evaluation (a log may carry poses
/// alone; a truncated log may end inside a frame's ground truth).

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/image.h"
#include "common/rig.h"
#include "common/status.h"
#include "eval/landmark_metrics.h"
#include "eval/map_metrics.h"
#include "eval/pose_consistency.h"
#include "io/json.h"
#include "io/trajectory.h"
#include "mapping/occupancy_mapper.h"
#include "pipeline/config.h"
#include "pipeline/run.h"
#include "sim/slip_truth.h"
#include "sim/world.h"

namespace twocam::eval {

/// Everything a run writes, built in memory (the writer stages and swaps it in, io/run_writer.h).
struct RunOutputs {
  /// Relative path and content of each text file (CSV, TUM), written as they are.
  std::vector<std::pair<std::string, std::string>> text_files;
  struct Png {
    std::string path;
    ImageU8 image;
  };
  std::vector<Png> pngs;
  io::Json metrics;  ///< metrics.json (deterministic: no wall-clock times)
  io::Json timing;   ///< timing.json (wall-clock stage times)
  /// Lines the CLI prints (frames, landmarks, map), each ending in '\n'.
  std::string summary;
  /// The map evaluation against the world was made (map_eval_voxels.csv written).
  bool map_evaluated = false;
  /// The sample frame was taken (sample_frame/ written).
  bool sample_taken = false;
};

class RunEvaluator {
 public:
  struct Inputs {
    std::string log_path;  ///< recorded in metrics.json
    /// World of a simulated log for the map evaluation, or nullptr; then `world_absent` says why
    /// (metrics.json "octomap": {"absent": reason}).
    const sim::World* world = nullptr;
    std::string world_absent;
    /// Frame index drawn in sample_frame/ (the first processed frame at or after it).
    int sample_frame = 0;
    /// What made the log's odometry when no wheel measured it (`twocam import-kitti
    /// --synthetic-odometry`, io::RawlogReader::syntheticOdometry): metrics.json
    /// `odometry_synthetic` and a summary line say so, so that results on it are not mistaken
    /// for real odometry.
    std::optional<std::string> synthetic_odometry;
    /// The log's true slip events (metrics.json `slips.*`, slip_events.csv), from the world
    /// file or from the slips sidecar of `twocam import-kitti --synthetic-odometry`
    /// (sim/slip_truth.h); `true_slips_source` names the file. Without them `slips` is
    /// {"absent": true_slips_absent}.
    std::optional<std::vector<sim::TrueSlip>> true_slips;
    std::string true_slips_source;
    std::string true_slips_absent =
        "no world file and no slips file, so the true slip events "
        "are unknown";
  };

  RunEvaluator(const StereoRig& rig, const pipeline::PipelineConfig& config, Inputs inputs);
  ~RunEvaluator();

  /// pipeline::RunCallbacks::on_frame. Errors: ground truth that cannot be evaluated (a true
  /// pose that is not finite or absurdly far, eval/landmark_metrics.h checkGroundTruthPose).
  [[nodiscard]] Status addFrame(const pipeline::RunFrame& frame);

  /// Landmarks the tracker's working set paged out (pipeline::MapSession::takePagedOut): their
  /// last records are judged with the landmarks still in the tracker at the end (the landmark
  /// metrics and landmarks.csv cover every landmark the run made, not only the final working
  /// set); a landmark paged back in is a restored one there (counted apart).
  void addPagedOut(std::vector<landmarks::Landmark> records);

  /// The run's outputs from the finished run. Errors: the trajectory evaluation fails.
  [[nodiscard]] Status finish(const pipeline::Run& run, RunOutputs* out) const;
  /// The true body poses of the processed frames that had one.
  [[nodiscard]] const std::vector<io::TimedPose>& groundTruthTrack() const { return gt_track_; }

 private:
  /// The run's mapped rays placed again with other poses (the true ones, or odometry's): each
  /// landmark moves with the correction (target pose x used pose^-1) of its anchor frame, where
  /// its position was measured, and the ray starts at the target camera.
  struct ReplacedMap {
    explicit ReplacedMap(const mapping::MappingOptions& options) : mapper(options) {}
    void addFrame(const pipeline::RunFrame& frame, const Eigen::Isometry3d& T_w_b_target);
    mapping::OccupancyMapper mapper;
    std::vector<Eigen::Isometry3d> T_target_used_by_frame;
  };
  void takeSample(const pipeline::RunFrame& frame, const GroundTruthFrame* gt);
  [[nodiscard]] std::string landmarksCsv(const std::vector<landmarks::Landmark>& slots,
                                         bool has_gt) const;

  StereoRig rig_;
  pipeline::PipelineConfig config_;
  Inputs inputs_;
  LandmarkEvaluator landmarks_;
  /// With a world: the map built with the true poses (octomap.oracle_poses) and, when the run
  /// localises, with the odometry poses (octomap.odometry_frame; in odometry mode that is the
  /// run's own map); the observable surface voxels (octomap.completeness).
  std::unique_ptr<ReplacedMap> oracle_map_;
  std::unique_ptr<ReplacedMap> odometry_map_;
  std::unique_ptr<ObservableVoxels> observable_;
  std::vector<io::TimedPose> gt_track_;
  /// Every processed frame so far had a true pose and depth (has_gt_), a true pose (has_pose_gt_).
  bool has_gt_ = true;
  bool has_pose_gt_ = true;
  /// Logs with true poses but no true depth (KITTI): landmarks.true_pose_consistency.
  TruePoseConsistency pose_consistency_;
  /// addPagedOut()'s records.
  std::vector<landmarks::Landmark> paged_out_;
  bool sample_taken_ = false;
  int sample_index_ = 0;
  ImageU8 sample_left_, sample_right_;
  std::string sample_csv_;
};

}  // namespace twocam::eval
