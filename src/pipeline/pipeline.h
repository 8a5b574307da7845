#pragma once
/// The per-frame pipeline of `twocam run` and of the pipeline benchmark: frontend (Harris + 1-D
/// SAD hypotheses) -> landmark database -> occupancy map of the confirmed landmarks seen in the
/// frame. State only; each stage's maths live in its module.

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/rig.h"
#include "common/status.h"
#include "frontend/frontend.h"
#include "landmarks/landmark_database.h"
#include "localization/pose_search.h"
#include "localization/pose_update.h"
#include "localization/slip_test.h"
#include "mapping/occupancy_mapper.h"
#include "pipeline/config.h"

namespace twocam::pipeline {

/// Wall time of each stage of one frame [ms] (single thread).
struct StageTimes {
  double frontend_ms = 0.0;
  double landmarks_ms = 0.0;
  double mapping_ms = 0.0;
  double localization_ms = 0.0;  ///< the pose update (0 in odometry mode)
  [[nodiscard]] double totalMs() const {
    return frontend_ms + landmarks_ms + mapping_ms + localization_ms;
  }
};

/// What one frame produced. Refers to the pipeline's state: valid until the next call.
struct FrameOutput {
  /// Which stage refused the frame when process() returned an error.
  enum class Failure { kNone, kFrontend, kLandmarks };
  Failure failure = Failure::kNone;
  StageTimes times;
  /// Confirmed landmarks observed in this frame (odometry world frame) [m]: the map's rays end
  /// there; and the left camera centre they start from [m].
  std::vector<Eigen::Vector3d> mapped_points_w;
  /// Landmark id of each mapped point, parallel to mapped_points_w (database().find(id)).
  std::vector<uint64_t> mapped_ids;
  Eigen::Vector3d camera_origin_w = Eigen::Vector3d::Zero();
  /// The body pose this frame used (landmarks, map) in the robot's world frame: the odometry
  /// pose in odometry mode, else the estimate.
  Pose2 pose;
  /// Localisation (pnp, fused): the pose used visual measurements, and how many confirmed
  /// landmarks it used (inliers); observations offered to it.
  bool visual = false;
  int landmarks_used = 0;
  int landmarks_observed = 0;
  /// Fused: a frame the slip test flagged as an odometry outlier in this frame's window, or -1.
  int32_t slip_frame = -1;
  /// Fused: the slip search's check (localization/pose_search.h): reference landmarks in view
  /// of the prediction and how many of them it explained; whether the search ran, and whether
  /// its pose replaced the prediction.
  int search_reference = 0;
  int search_prediction_score = 0;
  /// Of the prediction's matches, how many chance alone would give (PoseSearchResult::
  /// chance_score).
  double search_chance_score = 0.0;
  bool searched = false;
  bool search_accepted = false;
  /// Searched: the best searched pose's matches, the best distinct rival's, and its correction
  /// of the prediction (PoseSearchResult::best_score, rival_score, best_correction).
  int search_best_score = 0;
  int search_rival_score = 0;
  /// Searched against the recent reference: the references in view of the best searched pose
  /// and its chance matches (PoseSearchResult::best_reference, best_chance_score).
  int search_best_reference = 0;
  double search_best_chance_score = 0.0;
  Pose2 search_correction;
  /// Fused: the earlier map's landmarks the last frame predicted in view but did not associate
  /// (the re-anchoring check's reference, in view of this frame's prediction), and whether the
  /// search against them replaced the prediction.
  int reanchor_reference = 0;
  bool reanchored = false;
  /// The camera was outside the octree's extent (about +-1.6 km at 5 cm resolution): the frame
  /// was not mapped (landmarks were still updated).
  bool outside_map = false;
};

class Pipeline {
 public:
  /// `config` must be valid and its disparity range must fit the rig (see clampToRig).
  Pipeline(const StereoRig& rig, const PipelineConfig& config);

  /// One stereo frame with its odometry pose: frontend, then the landmark database's frame in
  /// steps (LandmarkDatabase::beginFrame), with the unassociated candidates re-measured on the
  /// frame's images (Frontend::measureAt, ConsistencyOptions::probe_unseen), then the map. An error
  /// from the landmark database (NaN pose, time going backwards) leaves the database and map
  /// unchanged: the caller may skip the frame and go on. A frontend error (image of the wrong
  /// size) is returned as well; an error of the re-measurement leaves the frame unscored.
  Status process(int32_t frame,
                 const StereoFrame& stereo,
                 const Pose2& odom_pose,
                 FrameOutput* out);

  /// Frontend only (a log without odometry): corners and hypotheses, no landmarks, no map.
  Status processFrontendOnly(const StereoFrame& stereo, FrameOutput* out);

  /// For frontend-only runs, before the first frame: only the landmark database reads the row
  /// support (frontend.sad.row_support), so the frontend stops measuring it (EuRoC micro, 7700
  /// hypotheses per frame: 1.94 against 2.57 ms per frame, README).
  void skipRowSupport();

  /// Landmarks and map from hypotheses made elsewhere (another matcher, e.g. the OpenCV
  /// reference in pipeline_bench); out->times.frontend_ms stays 0. Copies the hypotheses.
  /// Without images there is nothing to re-measure, so ConsistencyOptions::probe_unseen is idle.
  Status processHypotheses(int32_t frame,
                           int64_t t_ns,
                           const Pose2& odom_pose,
                           const StereoHypotheses& hypotheses,
                           FrameOutput* out);

  /// Between frames: confirmed landmarks at these positions in the run's world frame join the
  /// database (landmarks::LandmarkDatabase::restoreConfirmed); returns their ids.
  std::vector<uint64_t> restoreLandmarks(const std::vector<Eigen::Vector3d>& p_w) {
    std::vector<uint64_t> ids;
    db_.restoreConfirmed(p_w, &ids);
    return ids;
  }

  /// Between frames: these confirmed landmarks leave the database without being removed
  /// (landmarks::LandmarkDatabase::pageOut; the working set, pipeline/working_set.h).
  int pageOutLandmarks(const std::vector<uint64_t>& ids) { return db_.pageOut(ids); }

  [[nodiscard]] const frontend::Frontend& frontend() const { return frontend_; }
  [[nodiscard]] const landmarks::LandmarkDatabase& database() const { return db_; }
  [[nodiscard]] const mapping::OccupancyMapper& mapper() const { return mapper_; }
  [[nodiscard]] const StereoHypotheses& hypotheses() const { return hyps_; }
  [[nodiscard]] const landmarks::FrameReport& report() const { return report_; }

 private:
  Status landmarksAndMap(int32_t frame,
                         int64_t t_ns,
                         const Pose2& odom_pose,
                         const StereoHypotheses& hyps,
                         FrameOutput* out,
                         const StereoFrame* images);

  /// The frame's pose (localization.mode): odometry, or predicted then corrected between the
  /// database's association and its scoring. Errors only from the database.
  Status localize(int32_t frame, const Pose2& odom_pose, FrameOutput* out);

  StereoRig rig_;
  localization::LocalizationOptions loc_options_;
  OdometryNoise odometry_noise_;
  bool has_estimate_ = false;
  localization::PoseWithCovariance estimate_;
  Pose2 previous_odom_;
  std::vector<localization::LandmarkObservation> loc_obs_;
  /// The slip search, and its reference: the confirmed landmarks the last visual updates used.
  localization::PoseSearch search_;
  std::vector<uint64_t> reference_ids_;
  std::deque<std::vector<uint64_t>> recent_inliers_;  // per recent visual frame, oldest first
  std::vector<Eigen::Vector3d> reference_w_;
  /// Confirmed landmarks the last frame predicted in view but did not associate, not seen within
  /// the reference window, the max_reference most observed: the earlier map's check of the pose
  /// (re-anchoring, see landmarksAndMap).
  std::vector<uint64_t> stale_ids_;
  frontend::Frontend frontend_;
  landmarks::LandmarkDatabase db_;
  mapping::OccupancyMapper mapper_;
  localization::SlipTest slip_test_;
  /// The last measured pose the estimate was not corrected to (a measured step on a frame
  /// without a visual pose) and the odometry there: the next measured step is tested against
  /// it (localization::odometryError), with the estimate's covariance as on any frame.
  bool step_carried_ = false;
  Pose2 carried_measured_pose_;
  Pose2 carried_odom_;
  StereoHypotheses hyps_;
  landmarks::FrameReport report_;
  StereoHypotheses probe_hyps_;  // the re-measurement's output, reused between frames
  std::vector<uint8_t> slot_mapped_;
  std::vector<uint32_t> mapped_slot_list_;  // slots flagged in slot_mapped_ this frame
};

/// Fits a config to a rig: the SAD disparity range is clamped so that the window stays inside
/// the image, and the landmark database's range follows the frontend's. Then validates.
Status clampToRig(const StereoRig& rig, PipelineConfig* config);

}  // namespace twocam::pipeline
