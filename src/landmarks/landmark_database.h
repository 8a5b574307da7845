#pragma once
/// The landmark database (Paper A §5.5, "spurious matching"): every stereo hypothesis becomes a
/// candidate 3D landmark; wheel odometry predicts where each should reappear. The database is
/// the policy-agnostic tracker (slots, prediction, gating, association, life cycle, caps, stable
/// landmark ids); what hits and misses mean for a candidate, and when it is confirmed, is the
/// confirmation policy's (landmarks/confirmation_policy.h, one implementation per policy).
/// Model, parameters and their defaults: docs/landmarks.md.
///
/// Frames: w = odometry world frame (equals the true world at the first frame), b = robot body,
/// cl = left camera optical frame. A landmark's position p_w is in the odometry world frame.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/rig.h"
#include "common/status.h"
#include "landmarks/confirmation_policy.h"
#include "landmarks/id_index.h"
#include "landmarks/landmark.h"
#include "landmarks/options.h"

namespace twocam::landmarks {

/// What happened in one update.
struct FrameReport {
  int32_t frame = 0;
  int hypotheses = 0;
  int predicted_visible = 0;
  int associated = 0;
  int seeded = 0;
  int confirmed = 0;
  int pruned = 0;
  int refined = 0;
  /// Candidates re-measured at their predicted pixel (ConsistencyOptions::probe_unseen), and how
  /// many of those measurements found them (one answer in the gate, with row support).
  int probed = 0;
  int probe_found = 0;
  /// Ids of the landmarks created this frame (read them through LandmarkDatabase::find()) and,
  /// in parallel, the index of the hypothesis each was seeded from (created_hypotheses).
  std::vector<uint64_t> created_ids;
  /// Ids of the landmarks associated with one of this frame's hypotheses (a hit), in the order
  /// of the predictions; each appears once.
  std::vector<uint64_t> associated_ids;
  /// Ids of the landmarks removed this frame.
  std::vector<uint64_t> removed_ids;
  /// Ids of the candidates confirmed this frame (in the order of confirmation).
  std::vector<uint64_t> confirmed_ids;
  /// Confirmed landmarks associated this frame (before the anchor check), and whether the
  /// estimate's gates gave too few of them and the odometry gates were used
  /// (LandmarkDatabase::setPredictionSigma).
  int associated_confirmed = 0;
  bool gates_widened = false;
  /// Confirmed landmarks associated by the second pass with the corrected pose
  /// (LandmarkDatabase::correctFramePose).
  int reassociated = 0;
  /// Candidates that were to be confirmed where a confirmed landmark already is (within
  /// TrackerOptions::fuse_radius_px and fuse_disparity_px in this frame): the same point, so the
  /// candidate was dropped (in removed_ids) and its measurement of this frame, if any, given to
  /// the confirmed landmark, instead of a second confirmation.
  int fused = 0;
  /// Corners not seeded because a confirmed landmark that was not associated is predicted on
  /// them (within the fusion radius): that landmark takes the corner.
  int reclaimed = 0;
  /// (dropped candidate id, confirmed landmark id) of each fusion.
  std::vector<std::pair<uint64_t, uint64_t>> fused_ids;
  /// Per input hypothesis: id of the landmark it was associated with or seeded into, or 0 (ids
  /// start at 1). An associated landmark may still have been removed later in the same update
  /// (removed_ids): find() then returns nullptr.
  std::vector<uint64_t> hypothesis_landmark_id;

  /// Index of the hypothesis each created landmark was seeded from, parallel to created_ids.
  std::vector<uint32_t> created_hypotheses;
};

/// The tracker: candidates and confirmed landmarks with their confidence. State only; the maths
/// (prediction, gating, evidence, refinement) are free functions in landmark_model.h and refine.h.
class LandmarkDatabase final : public AnchorPoses {
 public:
  /// CHECK-fails on an invalid rig or options (validate them first: a programmer error here).
  LandmarkDatabase(const StereoRig& rig, const LandmarkOptions& options);

  /// Processes one stereo frame without re-measuring unseen candidates: beginFrame() then
  /// finishFrame(). Replayed hypotheses (no images) use this; ConsistencyOptions::probe_unseen is
  /// then idle. Errors as beginFrame().
  Status update(int32_t frame,
                int64_t t_ns,
                const Pose2& odom_pose,
                const StereoHypotheses& hypotheses,
                FrameReport* report);

  /// One frame in steps, so that the caller can re-measure the unseen candidates on the frame's
  /// images (ConsistencyOptions::probe_unseen) between association and scoring:
  ///   beginFrame()      predicts every live landmark with the odometry pose and associates;
  ///   probeRequests()   the predicted pixels of the candidates predicted visible but not
  ///                     associated (empty unless probe_unseen and the consistency policy);
  ///   addProbeResults() the frontend's measurements at those pixels (Frontend::measureAt);
  ///   finishFrame()     scores, confirms, refines, prunes, seeds and enforces the caps.
  /// The probe steps may be skipped. `frame` counts from 0 in log order and must increase;
  /// t_ns must not go backwards. beginFrame returns an error, leaving the database unchanged,
  /// for a non-finite pose, a frame index or time stamp that goes backwards, or hypotheses that
  /// reference missing points. `hypotheses` and `report` must stay alive until finishFrame.
  /// A frame left unfinished (the probe failed: the run cannot go on) keeps its associations
  /// but is not scored.
  Status beginFrame(int32_t frame,
                    int64_t t_ns,
                    const Pose2& odom_pose,
                    const StereoHypotheses& hypotheses,
                    FrameReport* report);
  /// Left pixels to re-measure, in a fixed order; valid until addProbeResults or finishFrame.
  [[nodiscard]] const std::vector<Corner>& probeRequests();
  /// `measured`: one SalientPoint per requested pixel whose window fits the image, in request
  /// order, each with its hypotheses. Marks the candidates found there (one answer inside the
  /// gate, with row support) as neither hit nor missed. Error (nothing marked) when a point is at
  /// a pixel that was not requested.
  Status addProbeResults(const StereoHypotheses& measured);
  void finishFrame();

  /// Localisation, before beginFrame(): the standard deviations of the error of the pose that
  /// frame predicts with, relative to the map (the estimator's predicted covariance), or nullopt
  /// (odometry: every gate grows with the odometry path since its landmark was last seen). With
  /// it, confirmed landmarks are first gated by kMapPoseErrorFactor x that error (never wider
  /// than the odometry gate), so that gates tighten once vision holds and a confirmed landmark
  /// back in view is not lost in a gate full of other corners. When that pass associates fewer
  /// than kWidenBelowFraction of the previous frame's confirmed associations (a slip: the
  /// prediction is off by more than its covariance says) the odometry gates are tried as well
  /// and the pass with more confirmed associations is kept (FrameReport::gates_widened).
  void setPredictionSigma(const std::optional<OdometryErrorSigma>& sigma) {
    prediction_sigma_ = sigma;
  }
  /// A confirmed landmark's position was placed with an earlier estimate whose error is of the
  /// same size as the predicting pose's, and independent of it: the relative error is sqrt(2)
  /// times the pose's.
  static constexpr double kMapPoseErrorFactor = 1.4142135623730951;
  static constexpr double kWidenBelowFraction = 0.5;

  /// Between beginFrame() and finishFrame(): the frame's pose corrected by localisation
  /// (localization/pose_update.h). The landmarks associated this frame are re-placed from their
  /// measurements with it, the candidates' observations of this frame take it, and scoring,
  /// confirmation and seeding use it. Association and the anchor check were made with the pose
  /// given to beginFrame (the prediction). Error, nothing changed, for a non-finite pose.
  ///
  /// With `sigma` (the corrected pose's error relative to the map, from the estimator's
  /// covariance), a second association pass: the confirmed landmarks predicted visible but not
  /// associated (missed, or their prediction gate held several corners) are predicted again with
  /// the corrected pose and gated by kMapPoseErrorFactor x sigma (never wider than their
  /// odometry gate), against the corners that no landmark explains, which would otherwise be
  /// seeded as new candidates: a landmark back in view is re-associated, not confirmed again.
  /// A gate that holds more than one corner is still not associated.
  Status correctFramePose(const Pose2& pose,
                          const std::optional<OdometryErrorSigma>& sigma = std::nullopt);

  /// The observations of landmarks that were confirmed before this frame, associated in this
  /// frame: id, the landmark's map position p_w and the observed (u, v, d). Valid between
  /// beginFrame() and finishFrame().
  struct ConfirmedObservation {
    uint64_t id;
    Eigen::Vector3d p_w;
    float u_px, v_px, d_px;
  };
  [[nodiscard]] const std::vector<ConfirmedObservation>& confirmedObservations() const {
    return confirmed_obs_;
  }

  /// Between frames (after finishFrame): adds confirmed landmarks at these world positions, as
  /// if seen in the last frame (their gates start from its pose), e.g. a saved map's landmarks
  /// after relocalisation in it (pipeline/map_relocalizer.h). Their anchor is their projection in
  /// the last frame's left camera (zeros when out of view); they have no observations.
  /// Appends their ids to *ids when given. The max_confirmed cap applies at the next frame.
  void restoreConfirmed(const std::vector<Eigen::Vector3d>& p_w, std::vector<uint64_t>* ids);

  /// Between frames: the confirmed landmarks with these ids leave the database without being
  /// removed: their slots are freed but they are not reported in any FrameReport::removed_ids
  /// (the bounded working set, pipeline/working_set.h: a landmark store keeps them and hands
  /// them back with restoreConfirmed). Ids that are not live confirmed landmarks are skipped.
  /// Returns how many left.
  int pageOut(const std::vector<uint64_t>& ids);

  /// Between beginFrame() and finishFrame(): the confirmed landmarks that this frame's pose
  /// predicted in view, that no pass associated, and that were last seen before frame
  /// `seen_before`; of them the `max_count` with the most observations (ties: lower id first),
  /// in *ids (replaced) in increasing id order.
  void unassociatedConfirmedInView(int32_t seen_before,
                                   size_t max_count,
                                   std::vector<uint64_t>* ids);

  /// The live landmark with this id (candidate or confirmed), or nullptr. O(1).
  [[nodiscard]] const Landmark* find(uint64_t id) const;

  /// Every landmark record in storage order (for writing them all out); skip those in state
  /// kFree. Per-frame results name landmarks by id (FrameReport): look them up with find().
  [[nodiscard]] const std::vector<Landmark>& landmarks() const { return slots_; }
  [[nodiscard]] int numCandidates() const { return num_candidates_; }
  [[nodiscard]] int numConfirmed() const { return num_confirmed_; }
  [[nodiscard]] const LandmarkOptions& options() const { return options_; }
  [[nodiscard]] const StereoRig& rig() const { return rig_; }
  /// The confirmation policy (options().policy) with its per-landmark state.
  [[nodiscard]] const ConfirmationPolicy& policy() const { return *policy_; }

  /// T_w_cl of the landmark's anchor frame, from the ring of recent frames' poses when it is
  /// there (the anchor check needs it for every candidate association).
  [[nodiscard]] Eigen::Isometry3d anchorCameraPose(const Landmark& l) const override;

 private:
  /// Candidates seeded from one salient point at most (its rivals).
  static constexpr int kMaxRivals = 8;

  /// correctFramePose's second association pass.
  void reassociateConfirmed(const OdometryErrorSigma& sigma);
  struct Gate;
  /// A confirmed landmark's gate at predicted (u, v, d) and depth z_m for a pose error `sigma`
  /// relative to the map (kMapPoseErrorFactor x sigma, never wider than its odometry gate).
  [[nodiscard]] Gate estimateGate(const Landmark& l,
                                  const Eigen::Vector3d& uvd,
                                  double z_m,
                                  const OdometryErrorSigma& sigma) const;
  /// Calls visit(entry, hypothesis index) for every hypothesis in the grid cells a gate of
  /// half-widths (gate_u, gate_v) round (u, v) spans, row by row, until visit returns false.
  template <typename Visit>
  void scanGate(double u, double v, double gate_u, double gate_v, Visit&& visit) const;
  uint32_t allocateSlot();
  void releaseSlot(uint32_t slot, FrameReport* report);
  void predictAll(const Eigen::Isometry3d& T_cl_w, const StereoHypotheses& hyps);
  void associate(const StereoHypotheses& hyps, FrameReport* report);
  /// Returns false when the policy refused the observation (not recorded).
  bool applyObservation(uint32_t slot, const DisparityHypothesis& h, const Corner& c);
  void scoreAndLifeCycle(FrameReport* report);
  void confirm(uint32_t slot, FrameReport* report);
  /// Fusion at confirmation (TrackerOptions::fuse_radius_px): the confirmed landmark nearest to
  /// the candidate in this frame's image within the fusion radius, or -1. The index of this
  /// frame's confirmed landmarks by pixel is built at the first call of a frame.
  int64_t findFusionPartner(uint32_t slot);
  /// The confirmed landmark predicted nearest to (u, v, d) within the fusion radius, or -1.
  int64_t nearestConfirmed(const Eigen::Vector3d& uvd,
                           int64_t exclude_slot,
                           bool unassociated_only);
  void buildFusionIndex();
  /// At seeding: a confirmed landmark not associated this frame whose prediction lies within the
  /// fusion radius of one of the point's hypotheses takes that hypothesis; true when one did (the
  /// point is then not seeded).
  bool reclaimByConfirmed(const SalientPoint& point,
                          const StereoHypotheses& hyps,
                          FrameReport* report);
  void fuseInto(uint32_t candidate, uint32_t target, FrameReport* report);
  bool projectForFusion(uint32_t slot, Eigen::Vector3d* uvd) const;
  /// Indexes a confirmed landmark whose prediction error (sigma_u_px, sigma_v_px) is small
  /// enough that a corner within the fusion radius is more likely its own than another
  /// (kFusionMinLikelihoodRatio); the others are not fused.
  void addToFusionIndex(uint32_t slot, double sigma_u_px, double sigma_v_px);
  static constexpr double kFusionMinLikelihoodRatio = 1.0;
  static int64_t fusionKey(int64_t cu, int64_t cv);
  static constexpr double kFusionCellPx = 4.0;
  void seed(const StereoHypotheses& hyps, FrameReport* report);
  void enforceCaps(FrameReport* report);

  /// What the per-frame visibility test of every slot reads, kept apart from the (much larger)
  /// Landmark records so that the scan over thousands of out-of-view landmarks stays in cache.
  /// Mirrors Landmark::state and Landmark::p_w_last.
  struct HotSlot {
    Eigen::Vector3d p_w_last = Eigen::Vector3d::Zero();
    LandmarkState state = LandmarkState::kFree;
  };

  StereoRig rig_;
  LandmarkOptions options_;
  Eigen::Isometry3d T_b_cl_;
  std::unique_ptr<ConfirmationPolicy> policy_;
  std::vector<Landmark> slots_;
  std::vector<HotSlot> hot_;  // parallel to slots_
  /// Camera poses of the last kPoseRingSize frames, indexed by frame % kPoseRingSize.
  static constexpr uint32_t kPoseRingSize = 256;
  struct PoseRingEntry {
    int32_t frame = -1;
    Eigen::Isometry3d T_w_cl = Eigen::Isometry3d::Identity();
  };
  std::vector<PoseRingEntry> pose_ring_ = std::vector<PoseRingEntry>(kPoseRingSize);
  std::vector<uint32_t> free_slots_;
  uint64_t next_id_ = 1;
  int num_candidates_ = 0;
  int num_confirmed_ = 0;

  // Per-frame state, kept between frames so that capacity is reused.
  int32_t frame_ = -1;
  int64_t t_ns_ = 0;
  bool has_previous_ = false;
  Pose2 pose_;
  Eigen::Isometry3d T_w_cl_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cl_w_ = Eigen::Isometry3d::Identity();
  double path_m_ = 0.0;
  double turn_rad_ = 0.0;
  FrameContext frame_ctx_;  // the same, as the policy reads it
  std::vector<Prediction> predictions_;
  std::vector<uint8_t> visible_;       // per slot, this frame
  std::vector<uint8_t> associated_;    // per slot, this frame
  std::vector<uint8_t> contradicted_;  // per slot, this frame: the policy refused the hit
  std::vector<int32_t> hyp_claim_;     // per hypothesis: prediction index, or -1
  std::vector<float> hyp_claim_d2_;
  std::vector<int32_t> cell_start_;  // per index cell: first index into grid_items_ / grid_uvd_
  std::vector<int32_t> grid_items_;  // hypothesis indices in cell order
  /// Per grid item, in the same order: the hypothesis's corner, disparity and point.
  struct GridEntry {
    float u, v, d;
    uint32_t point_index;
  };
  std::vector<GridEntry> grid_uvd_;
  std::vector<uint32_t> rivals_;                      // confirm()'s buffer
  std::vector<std::pair<int64_t, uint64_t>> ranked_;  // unassociatedConfirmedInView's buffer
  struct FusionEntry {
    uint32_t slot;
    float u, v, d;
  };
  std::unordered_map<int64_t, std::vector<FusionEntry>> fusion_index_;
  bool fusion_index_built_ = false;
  /// This frame's applied observations: slot and measurement (correctFramePose re-places them).
  struct FrameObservation {
    uint32_t slot;
    float u_px, v_px, d_px;
  };
  std::vector<FrameObservation> frame_obs_;
  std::vector<ConfirmedObservation> confirmed_obs_;
  double hypothesis_density_ = 0.0;  // hypotheses per pixel^2 per disparity pixel
  double corner_density_ = 0.0;      // salient points per pixel^2, this frame
  /// setPredictionSigma(); the gates of confirmed predictions with it, parallel to predictions_
  /// (used only when has_tight_gates_); the previous frame's confirmed associations.
  struct Gate {
    float inv_var_u, inv_var_v, inv_var_d, gate_u, gate_v;
  };
  std::optional<OdometryErrorSigma> prediction_sigma_;
  std::vector<Gate> tight_gates_;
  bool has_tight_gates_ = false;
  /// With localisation (setPredictionSigma) confirmed landmarks are predicted from their map
  /// position p_w, in the frame the estimator holds, not from their last measurement (which
  /// follows odometry drift when there is no estimate).
  bool map_frame_predictions_ = false;
  int previous_associated_confirmed_ = 0;
  // The probe's per-frame buffers (reused): pixels and the prediction each stands for.
  std::vector<Corner> probe_pixels_;
  std::vector<uint32_t> probe_prediction_;
  std::vector<uint8_t> probed_;  // per slot: found by this frame's probe (neither hit nor miss)
  bool probe_requests_built_ = false;
  /// The frame between beginFrame and finishFrame.
  const StereoHypotheses* frame_hyps_ = nullptr;
  FrameReport* frame_report_ = nullptr;
  /// Live landmarks: id -> slot.
  IdIndex slot_of_id_;
};

}  // namespace twocam::landmarks
