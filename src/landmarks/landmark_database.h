#pragma once
/// The landmark database (Paper A §5.5, "spurious matching"): every stereo hypothesis becomes a
/// candidate 3D landmark; wheel odometry predicts where each should reappear; hits, misses and
/// rivalry between hypotheses of the same corner decide which ones are confirmed.
/// Model, parameters and their defaults: docs/landmarks.md.
///
/// Frames: w = odometry world frame (equals the true world at the first frame), b = robot body,
/// cl = left camera optical frame. A landmark's position p_w is in the odometry world frame.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/rig.h"
#include "common/status.h"
#include "landmarks/options.h"

namespace twocam::landmarks {

/// One associated stereo measurement of a landmark, with the odometry pose of its frame.
struct Observation {
  int32_t frame = 0;
  float u_px = 0.0f;
  float v_px = 0.0f;
  float d_px = 0.0f;
  Pose2 odom_pose;
};

enum class LandmarkState : uint8_t { kFree, kCandidate, kConfirmed };

/// A landmark as the database keeps it. Plain data; read through LandmarkDatabase::landmarks().
struct Landmark {
  uint64_t id = 0;
  LandmarkState state = LandmarkState::kFree;
  /// Position estimate in the odometry world frame [m]: the anchor's triangulation until the
  /// landmark is confirmed, then the multi-view refinement.
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
  /// Position from the latest observation [m]; predictions start here so that only the odometry
  /// error since the landmark was last seen enters the gate.
  Eigen::Vector3d p_w_last = Eigen::Vector3d::Zero();
  /// The observation that created the landmark (frames counted from 0 in log order).
  Observation anchor;
  int32_t first_frame = 0;
  int32_t confirmed_frame = -1;
  int32_t last_seen_frame = 0;
  int64_t first_t_ns = 0;
  /// Odometry path length and absolute turn (since the run started) when last seen and when
  /// evidence was last counted [m], [rad].
  double path_at_last_seen_m = 0.0;
  double turn_at_last_seen_rad = 0.0;
  double path_at_last_evidence_m = 0.0;
  double path_at_anchor_m = 0.0;
  double turn_at_anchor_rad = 0.0;
  /// Consistency policy: the consistent re-observations favour this candidate over the
  /// phantoms of a rival depth by at least LandmarkOptions::verify_llr (see checkAgainstAnchor).
  bool verified = false;
  /// Consistency policy: largest parallax of a consistent re-observation so far, the angle at
  /// the anchor point between the anchor's and the observation's left-camera centres [rad];
  /// no longer updated once it reaches LandmarkOptions::min_parallax_deg.
  float max_parallax_rad = 0.0f;
  /// Number of hypotheses of the corner when the candidate was created (1 = no rivals).
  uint8_t rivals_at_creation = 1;
  /// Consistency policy: AnchorCheck::phantom_llr summed over the consistent re-observations,
  /// for the phantom below and above the anchor disparity [nats].
  float phantom_llr[2] = {0.0f, 0.0f};
  /// Consistency policy, complete hypothesis lists (LandmarkOptions::verify_own_rivals): the
  /// disparities of the nearest rival below and above the anchor's [px], the real points those
  /// phantoms stand for; 0 = no rival on that side. Unused (own_phantoms false) otherwise.
  float phantom_d_px[2] = {0.0f, 0.0f};
  bool own_phantoms = false;
  /// Rival group (hypotheses of the same corner in the creating frame) and this member's prior.
  uint32_t group = 0;
  float prior = 0.0f;
  /// Accumulated evidence log-likelihood ratio (consistency policy) [nats].
  float evidence = 0.0f;
  /// Policy-specific confidence in [0, 1] (consistency: rival-normalised existence probability).
  float confidence = 0.0f;
  int32_t n_obs = 0;
  int32_t n_visible = 0;
  int32_t consecutive_misses = 0;
  /// Observations (anchor included) whose hypothesis lacked row support (see
  /// LandmarkOptions::max_row_span_px).
  int32_t n_row_unsupported = 0;
  int32_t frames_out_of_view = 0;
  /// SVO seed (inlier-ratio policy): inverse depth along the anchor ray [1/m], its variance, the
  /// Beta parameters and the inverse-depth range.
  float svo_mu = 0.0f;
  float svo_sigma2 = 0.0f;
  float svo_a = 10.0f;
  float svo_b = 10.0f;
  float svo_range = 0.0f;
  /// Candidates: the anchor plus the most recent observations (at most
  /// LandmarkOptions::max_observations), for the refinement at confirmation. Emptied when the
  /// landmark is confirmed (confirmed landmarks are not re-refined).
  std::vector<Observation> observations;
};

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
  /// Candidates re-measured at their predicted pixel (LandmarkOptions::probe_unseen), and how
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
  /// Per input hypothesis: id of the landmark it was associated with or seeded into, or 0 (ids
  /// start at 1). An associated landmark may still have been removed later in the same update
  /// (removed_ids): find() then returns nullptr.
  std::vector<uint64_t> hypothesis_landmark_id;

  /// Deprecated: slot-based, use created_ids. Slots of the landmarks created this frame.
  std::vector<uint32_t> created_slots;
  /// Index of the hypothesis each created landmark was seeded from, parallel to created_ids
  /// (and created_slots).
  std::vector<uint32_t> created_hypotheses;
  /// Deprecated: slot-based, use hypothesis_landmark_id. Per input hypothesis: slot of the
  /// landmark it was associated with or seeded into, or -1.
  std::vector<int32_t> hypothesis_landmark;
};

/// The database: candidates and confirmed landmarks with their confidence. State only; the maths
/// (prediction, gating, evidence, refinement) are free functions in landmark_model.h and refine.h.
class LandmarkDatabase {
 public:
  /// CHECK-fails on an invalid rig or options (validate them first: a programmer error here).
  LandmarkDatabase(const StereoRig& rig, const LandmarkOptions& options);

  /// Processes one stereo frame without re-measuring unseen candidates: beginFrame() then
  /// finishFrame(). Replayed hypotheses (no images) use this; LandmarkOptions::probe_unseen is
  /// then idle. Errors as beginFrame().
  Status update(int32_t frame,
                int64_t t_ns,
                const Pose2& odom_pose,
                const StereoHypotheses& hypotheses,
                FrameReport* report);

  /// One frame in steps, so that the caller can re-measure the unseen candidates on the frame's
  /// images (LandmarkOptions::probe_unseen) between association and scoring:
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

  /// The live landmark with this id (candidate or confirmed), or nullptr. O(1).
  [[nodiscard]] const Landmark* find(uint64_t id) const;

  /// Deprecated: slot-based, use find() and the ids of FrameReport. All slots; skip those in
  /// state kFree.
  [[nodiscard]] const std::vector<Landmark>& landmarks() const { return slots_; }
  [[nodiscard]] int numCandidates() const { return num_candidates_; }
  [[nodiscard]] int numConfirmed() const { return num_confirmed_; }
  [[nodiscard]] const LandmarkOptions& options() const { return options_; }
  [[nodiscard]] const StereoRig& rig() const { return rig_; }

 private:
  struct RivalGroup {
    static constexpr int kMaxMembers = 8;
    uint32_t members[kMaxMembers] = {};
    uint8_t count = 0;
    /// Mass of members that left the group (pi_j exp(L_j)) and of "none is real".
    double removed_mass = 0.0;
    double none_mass = 0.0;
  };
  struct Prediction {
    uint32_t slot;
    float u, v, d;
    float inv_var_u, inv_var_v, inv_var_d;
    float gate_u, gate_v;
    float p_false_hit_per_hyp;
    bool confirmed;  // the landmark's state when predicted (read without touching slots_)
  };

  uint32_t allocateSlot();
  void releaseSlot(uint32_t slot, FrameReport* report);
  uint32_t allocateGroup();
  void removeFromGroup(uint32_t slot);
  void normaliseGroup(uint32_t group);
  void predictAll(const Eigen::Isometry3d& T_cl_w, const StereoHypotheses& hyps);
  void associate(const StereoHypotheses& hyps, FrameReport* report);
  /// Returns false when the observation contradicts the candidate's anchor (not recorded).
  [[nodiscard]] bool rowSupported(const DisparityHypothesis& h) const;
  /// Prior mass of "none of a point's hypotheses is real": 1 - prior_real.
  [[nodiscard]] double noneMass() const { return 1.0 - options_.consistency.prior_real; }
  bool applyObservation(uint32_t slot, const DisparityHypothesis& h, const Corner& c);
  /// T_w_cl of the landmark's anchor frame, from the ring of recent frames' poses when it is
  /// there (the anchor check needs it for every candidate association).
  [[nodiscard]] Eigen::Isometry3d anchorCameraPose(const Landmark& l) const;
  void scoreAndLifeCycle(FrameReport* report);
  void confirm(uint32_t slot, FrameReport* report);
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
  float min_parallax_rad_;  // options_.min_parallax_deg in radians
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
  std::vector<RivalGroup> groups_;
  std::vector<uint32_t> free_groups_;
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
  std::vector<Prediction> predictions_;
  std::vector<uint8_t> visible_;       // per slot, this frame
  std::vector<uint8_t> associated_;    // per slot, this frame
  std::vector<uint8_t> contradicted_;  // per slot, this frame: the hit disagreed with the anchor
  std::vector<uint8_t>
      informative_;  // per slot, this frame: the motion since the anchor exposes depth
  std::vector<int32_t> hyp_claim_;  // per hypothesis: prediction index, or -1
  std::vector<float> hyp_claim_d2_;
  std::vector<int32_t> cell_start_;  // per index cell: first index into grid_items_ / grid_uvd_
  std::vector<int32_t> grid_items_;  // hypothesis indices in cell order
  /// Per grid item, in the same order: the hypothesis's corner, disparity and point.
  struct GridEntry {
    float u, v, d;
    uint32_t point_index;
  };
  std::vector<GridEntry> grid_uvd_;
  std::vector<uint32_t> groups_touched_;
  std::vector<uint8_t> group_touched_flag_;
  double hypothesis_density_ = 0.0;  // hypotheses per pixel^2 per disparity pixel
  // The probe's per-frame buffers (reused): pixels and the prediction each stands for.
  std::vector<Corner> probe_pixels_;
  std::vector<uint32_t> probe_prediction_;
  std::vector<uint8_t> probed_;  // per slot: found by this frame's probe (neither hit nor miss)
  bool probe_requests_built_ = false;
  /// The frame between beginFrame and finishFrame.
  const StereoHypotheses* frame_hyps_ = nullptr;
  FrameReport* frame_report_ = nullptr;
  /// Live landmarks: id -> slot.
  std::unordered_map<uint64_t, uint32_t> slot_of_id_;
};

}  // namespace twocam::landmarks
