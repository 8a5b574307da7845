#include "pipeline/pipeline.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <optional>

#include "common/timer.h"
#include "landmarks/landmark_model.h"

namespace twocam::pipeline {
namespace {

/// Standard deviations of a planar pose covariance (x, y, yaw): the larger axis of the position
/// ellipse [m] and the heading [rad].
OdometryErrorSigma poseSigma(const Eigen::Matrix3d& cov) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> xy(cov.topLeftCorner<2, 2>());
  return {std::sqrt(std::max(0.0, xy.eigenvalues().maxCoeff())),
          std::sqrt(std::max(0.0, cov(2, 2)))};
}

/// References the slip search gathers from the last frame before it looks further back [-]:
/// a few times its fewest (PoseSearchOptions::min_reference), enough that most are in view.
constexpr size_t kEnoughReference = 50;

}  // namespace

Status clampToRig(const StereoRig& rig, PipelineConfig* config) {
  frontend::SalientSadOptions& sad = config->frontend.sad;
  sad.max_disparity_px = std::min(sad.max_disparity_px, rig.width_px - sad.window_width_px);
  config->landmarks.tracker.max_disparity_px = sad.max_disparity_px;
  config->landmarks.tracker.min_disparity_px = sad.min_disparity_px;
  return config->validate();
}

Pipeline::Pipeline(const StereoRig& rig, const PipelineConfig& config)
    : rig_(rig),
      loc_options_(config.localization),
      odometry_noise_(config.landmarks.tracker.odometry_noise),
      frontend_(config.frontend),
      db_(rig, config.landmarks),
      mapper_(config.mapping),
      slip_test_(config.localization.slip) {}

void Pipeline::skipRowSupport() {
  frontend::FrontendOptions options = frontend_.options();
  options.sad.row_support = false;
  frontend_ = frontend::Frontend(options);
}

Status Pipeline::processFrontendOnly(const StereoFrame& stereo, FrameOutput* out) {
  out->mapped_points_w.clear();
  out->mapped_ids.clear();
  out->outside_map = false;
  out->times = StageTimes{};
  out->failure = FrameOutput::Failure::kNone;
  const Timer t0;
  const Status s = frontend_.process(stereo, &hyps_);
  out->times.frontend_ms = t0.elapsedMs();
  if (!s) out->failure = FrameOutput::Failure::kFrontend;
  return s;
}

Status Pipeline::process(int32_t frame,
                         const StereoFrame& stereo,
                         const Pose2& odom_pose,
                         FrameOutput* out) {
  if (Status s = processFrontendOnly(stereo, out); !s) return s;
  return landmarksAndMap(frame, stereo.t_ns, odom_pose, hyps_, out, &stereo);
}

Status Pipeline::processHypotheses(int32_t frame,
                                   int64_t t_ns,
                                   const Pose2& odom_pose,
                                   const StereoHypotheses& hypotheses,
                                   FrameOutput* out) {
  out->mapped_points_w.clear();
  out->mapped_ids.clear();
  out->outside_map = false;
  out->times = StageTimes{};
  out->failure = FrameOutput::Failure::kNone;
  hyps_ = hypotheses;
  return landmarksAndMap(frame, t_ns, odom_pose, hyps_, out, nullptr);
}

Status Pipeline::landmarksAndMap(int32_t frame,
                                 int64_t t_ns,
                                 const Pose2& odom_pose,
                                 const StereoHypotheses& hyps,
                                 FrameOutput* out,
                                 const StereoFrame* images) {
  const Timer t1;
  // The pose the database predicts with: odometry, or the prediction from the last estimate.
  using localization::Mode;
  localization::PoseWithCovariance prediction;
  const bool localizing = loc_options_.mode != Mode::kOdometry;
  out->pose = odom_pose;
  out->visual = false;
  out->landmarks_used = out->landmarks_observed = 0;
  out->slip_frame = -1;
  double search_ms = 0.0;
  localization::PoseSearchResult sr;
  bool association_moved = false;
  Eigen::Isometry3d T_w_b_searched = Eigen::Isometry3d::Identity();  // the search's prediction
  Eigen::Matrix3d previous_cov = Eigen::Matrix3d::Zero();
  Pose2 increment;
  if (localizing) {
    if (has_estimate_) {
      increment = localization::odometryIncrement(previous_odom_, odom_pose);
      prediction = localization::predictPose(estimate_, increment, odometry_noise_);
      previous_cov = estimate_.cov;
    } else {
      prediction.T_w_b = toIsometry(odom_pose);  // the shared start pose
    }
    // The slip search: when the prediction explains too few of the landmarks the last update
    // used, a pose found from the frame's hypotheses replaces it.
    out->searched = out->search_accepted = false;
    out->search_reference = out->search_prediction_score = 0;
    out->search_chance_score = 0.0;
    out->search_best_score = out->search_rival_score = out->search_best_reference = 0;
    out->search_best_chance_score = 0.0;
    out->search_correction = Pose2{};
    out->reanchored = false;
    out->reanchor_reference = 0;
    const Timer ts;
    if (loc_options_.mode == Mode::kFused && loc_options_.search.enabled && has_estimate_) {
      reference_w_.clear();
      for (uint64_t id : reference_ids_) {
        const landmarks::Landmark* l = db_.find(id);
        if (l != nullptr && l->state == landmarks::LandmarkState::kConfirmed)
          reference_w_.push_back(l->p_w);
      }
      T_w_b_searched = prediction.T_w_b;
      sr = search_.run(
          rig_, prediction.T_w_b, prediction.cov, reference_w_, hyps, loc_options_.search);
      out->search_reference = sr.reference;
      out->search_prediction_score = sr.prediction_score;
      out->search_chance_score = sr.chance_score;
      out->searched = sr.searched;
      out->search_accepted = sr.accepted;
      out->search_best_score = sr.best_score;
      out->search_rival_score = sr.rival_score;
      out->search_best_reference = sr.best_reference;
      out->search_best_chance_score = sr.best_chance_score;
      out->search_correction = sr.best_correction;
      prediction.T_w_b = sr.T_w_b;
      // The reference is what the last frames saw: after a slip that went unnoticed (a blank
      // turn) the estimate and the landmarks placed with it since agree with each other, and
      // the search has nothing to find. The earlier map checks the pose too: its confirmed
      // landmarks that the last frame predicted in view but did not associate, the best
      // observed first (the likeliest to be real and seen from here; most of the others are
      // hidden behind nearer surfaces: the prediction ignores occlusion), at most
      // max_reference of them. The same search, with the same acceptance tests, re-anchors
      // the pose when they say it is off.
      if (!sr.accepted && loc_options_.search.reanchor && !stale_ids_.empty()) {
        reference_w_.clear();
        for (uint64_t id : stale_ids_) {
          const landmarks::Landmark* l = db_.find(id);
          if (l != nullptr && l->state == landmarks::LandmarkState::kConfirmed)
            reference_w_.push_back(l->p_w);
        }
        const localization::PoseSearchResult anchor =
            search_.run(rig_,
                        prediction.T_w_b,
                        prediction.cov,
                        reference_w_,
                        hyps,
                        loc_options_.search,
                        localization::WideSearch::kAfterHeadingSweep);
        out->reanchor_reference = anchor.reference;
        out->reanchored = anchor.accepted;
        if (anchor.accepted) prediction.T_w_b = anchor.T_w_b;
      }
    }
    search_ms = ts.elapsedMs();
    out->pose = localization::toPose2(prediction.T_w_b);
    // The database gates at the pose the reference landmarks measured when a heading within
    // the prediction's error passed the check (localization::associationPose); the update's
    // prior stays the prediction.
    if (!out->reanchored) {
      const Pose2 at = localization::toPose2(
          localization::associationPose(sr, prediction.T_w_b, loc_options_.search));
      association_moved =
          at.x_m != out->pose.x_m || at.y_m != out->pose.y_m || at.yaw_rad != out->pose.yaw_rad;
      out->pose = at;
    }
  }
  // Gates from the estimate's covariance once the estimator has one (the first frame's pose is
  // the shared start: its covariance is zero but no landmark is confirmed yet).
  std::optional<OdometryErrorSigma> prediction_sigma;
  if (localizing && loc_options_.estimate_gates && has_estimate_) {
    prediction_sigma = poseSigma(prediction.cov);
  }
  db_.setPredictionSigma(prediction_sigma);
  if (Status s = db_.beginFrame(frame, t_ns, out->pose, hyps, &report_); !s) {
    out->failure = FrameOutput::Failure::kLandmarks;
    return s;
  }
  if (localizing) {
    const Timer tl;
    loc_obs_.clear();
    for (const auto& o : db_.confirmedObservations()) {
      loc_obs_.push_back({o.id, o.p_w, o.u_px, o.v_px, o.d_px});
    }
    const localization::PoseUpdateResult r =
        loc_options_.mode == Mode::kFused
            ? localization::updatePose(rig_, prediction, loc_obs_, loc_options_.update)
            : localization::pnpPose(
                  rig_, prediction, loc_obs_, loc_options_.update, loc_options_.pnp);
    estimate_ = r.estimate;
    // The landmark database and the map take planar poses (landmarks/landmark_database.h), so
    // the estimate is kept planar too: otherwise height, roll and pitch, held only relative to
    // the prediction, would wander and the estimator's camera differ from the database's.
    estimate_.T_w_b = toIsometry(localization::toPose2(estimate_.T_w_b));
    const bool has_estimate_before = has_estimate_;
    has_estimate_ = true;
    previous_odom_ = odom_pose;
    out->visual = r.visual;
    out->landmarks_used = r.inliers;
    out->landmarks_observed = r.observations;
    if (r.visual) {
      // The reference: the landmarks the last visual update used (inliers), and those of the
      // updates before (up to reference_frames) while fewer than kEnoughReference, so that
      // after a few frames with little in view the check still has enough.
      recent_inliers_.emplace_back();
      for (size_t i = 0; i < loc_obs_.size(); ++i) {
        if (i < r.inlier.size() && r.inlier[i]) recent_inliers_.back().push_back(loc_obs_[i].id);
      }
      if (recent_inliers_.size() > static_cast<size_t>(loc_options_.search.reference_frames))
        recent_inliers_.pop_front();
      reference_ids_.clear();
      for (auto it = recent_inliers_.rbegin(); it != recent_inliers_.rend(); ++it) {
        if (reference_ids_.size() >= kEnoughReference) break;
        reference_ids_.insert(reference_ids_.end(), it->begin(), it->end());
      }
      std::sort(reference_ids_.begin(), reference_ids_.end());
      reference_ids_.erase(std::unique(reference_ids_.begin(), reference_ids_.end()),
                           reference_ids_.end());
    }
    if (!r.visual && association_moved) {
      // No visual pose: the frame is the prediction's (odometry with its grown covariance), not
      // the pose it was associated at.
      out->pose = localization::toPose2(estimate_.T_w_b);
      if (Status s = db_.correctFramePose(out->pose); !s) {
        out->failure = FrameOutput::Failure::kLandmarks;
        return s;
      }
    }
    if (r.visual) {
      out->pose = localization::toPose2(estimate_.T_w_b);
      std::optional<OdometryErrorSigma> posterior_sigma;
      if (loc_options_.estimate_gates) posterior_sigma = poseSigma(estimate_.cov);
      if (Status s = db_.correctFramePose(out->pose, posterior_sigma); !s) {
        out->failure = FrameOutput::Failure::kLandmarks;
        return s;
      }
    }
    // The slip test reads the step the reference landmarks measured against odometry's.
    // A step measured on a frame that the estimate was not corrected to stays in the
    // predictions after it: the next step is taken against that measured pose, so each error
    // is tested once.
    const bool fused = loc_options_.mode == Mode::kFused;
    if (!has_estimate_before) step_carried_ = false;
    if (fused && has_estimate_before && sr.step_measured) {
      Pose2 error = sr.step;
      Pose2 motion = increment;
      if (step_carried_) {
        motion = localization::odometryIncrement(carried_odom_, odom_pose);
        error = localization::odometryError(
            carried_measured_pose_,
            motion,
            localization::toPose2(T_w_b_searched * toIsometry(sr.step)));
      }
      out->slip_frame = slip_test_.add(
          frame,
          error,
          localization::stepCovariance(odometry_noise_, motion, error, previous_cov, sr.step_cov));
    }
    if (r.visual || sr.accepted || out->reanchored) {
      step_carried_ = false;
    } else if (fused && sr.step_measured) {
      step_carried_ = true;
      carried_measured_pose_ = localization::toPose2(T_w_b_searched * toIsometry(sr.step));
      carried_odom_ = odom_pose;
    }
    stale_ids_.clear();
    if (loc_options_.mode == Mode::kFused && loc_options_.search.enabled &&
        loc_options_.search.reanchor) {
      db_.unassociatedConfirmedInView(frame - loc_options_.search.reference_frames,
                                      static_cast<size_t>(loc_options_.search.max_reference),
                                      &stale_ids_);
    }
    out->times.localization_ms = tl.elapsedMs() + search_ms;
  }
  // Candidates whose corner was not detected are re-measured on this frame's images
  // (ConsistencyOptions::probe_unseen); replayed hypotheses (processHypotheses) have none. Its
  // time counts in the landmark stage.
  if (images != nullptr) {
    const std::vector<Corner>& pixels = db_.probeRequests();
    if (!pixels.empty()) {
      Status s = frontend_.measureAt(*images, pixels, &probe_hyps_);
      if (s) s = db_.addProbeResults(probe_hyps_);
      if (!s) {
        out->failure = FrameOutput::Failure::kLandmarks;
        if (s.message().rfind("frame ", 0) == 0) return s;
        return Status::error("frame " + std::to_string(frame) +
                             ": re-measuring unseen candidates: " + s.message());
      }
    }
  }
  db_.finishFrame();
  out->times.landmarks_ms = t1.elapsedMs() - out->times.localization_ms;

  // Map: one ray per confirmed landmark observed in this frame (a landmark is listed once even
  // when several hypotheses of its corner pointed at it).
  const Timer t2;
  // Read by id (FrameReport::hypothesis_landmark_id); the per-slot flags only deduplicate.
  const landmarks::Landmark* const first = db_.landmarks().data();
  if (slot_mapped_.size() < db_.landmarks().size()) slot_mapped_.resize(db_.landmarks().size(), 0);
  for (uint64_t id : report_.hypothesis_landmark_id) {
    if (id == 0) continue;
    const landmarks::Landmark* l = db_.find(id);
    if (l == nullptr || l->state != landmarks::LandmarkState::kConfirmed) continue;
    const auto slot = static_cast<size_t>(l - first);
    if (slot_mapped_[slot]) continue;
    slot_mapped_[slot] = 1;
    out->mapped_points_w.push_back(l->p_w);
    out->mapped_ids.push_back(l->id);
    mapped_slot_list_.push_back(static_cast<uint32_t>(slot));
  }
  for (uint32_t slot : mapped_slot_list_) slot_mapped_[slot] = 0;
  mapped_slot_list_.clear();
  out->camera_origin_w = landmarks::cameraPoseInWorld(out->pose, rig_.T_b_cl).translation();
  octomap::OcTreeKey origin_key;
  const octomap::point3d origin(static_cast<float>(out->camera_origin_w.x()),
                                static_cast<float>(out->camera_origin_w.y()),
                                static_cast<float>(out->camera_origin_w.z()));
  out->outside_map = !mapper_.tree().coordToKeyChecked(origin, origin_key);
  if (!out->outside_map) mapper_.insertFrame(out->camera_origin_w, out->mapped_points_w);
  out->times.mapping_ms = t2.elapsedMs();
  return Status::ok();
}

}  // namespace twocam::pipeline
