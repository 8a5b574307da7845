#pragma once
/// The confirmation-policy interface of the landmark tracker (landmarks/landmark_database.h).
/// The tracker (slots, prediction, gating, association, life cycle and caps) is the same for
/// every policy; a policy decides what a hit, a miss and a frame mean for a candidate's
/// confidence, and when it is confirmed or pruned. Each policy has its own options group
/// (landmarks/options.h) and keeps its own per-landmark state, indexed by the tracker's slot.
///
/// The tracker calls, per frame and in this order:
///   beginFrame()                          once, before association;
///   onAssociation() / onMeasured()        per association of a live landmark with a hypothesis;
///   scoreFrame()                          once, after the hits, misses and probe results are in;
///   decide()                              per live candidate still in the tracker's life cycle;
///   rivalsToRetire() / onConfirmed()      when a candidate is confirmed;
///   beginSeedGroup() / onSeed()           per salient point seeded, per candidate created;
/// and onRelease() whenever a slot is freed, onAllocate() whenever one is (re)used.
///
/// Implementations: ConsistencyPolicy (consistency_policy.h), WtaLrcPolicy, SeenCountPolicy,
/// CullingPolicy and InlierRatioPolicy (baseline_policies.h); makeConfirmationPolicy() picks one.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/rig.h"
#include "landmarks/landmark.h"
#include "landmarks/options.h"

namespace twocam::landmarks {

/// A live landmark predicted visible in the current frame (the tracker's gate).
struct Prediction {
  uint32_t slot;
  float u, v, d;
  float inv_var_u, inv_var_v, inv_var_d;
  float gate_u, gate_v;
  /// Chance that one hypothesis falls into the gate by accident (hypothesis density x gate
  /// volume), for the evidence of a hit or a miss.
  float p_false_hit_per_hyp;
  bool confirmed;  // the landmark's state when predicted (read without touching the records)
};

/// The current frame as the tracker knows it.
struct FrameContext {
  int32_t frame = 0;
  int64_t t_ns = 0;
  Pose2 odom_pose;
  /// Pose of the left camera in the odometry world frame and its inverse.
  Eigen::Isometry3d T_w_cl = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_cl_w = Eigen::Isometry3d::Identity();
  /// Odometry path length and absolute turn since the run started [m], [rad].
  double path_m = 0.0;
  double turn_rad = 0.0;
};

/// Pose of a landmark's anchor camera (T_w_cl of its anchor frame), from the tracker's ring of
/// recent poses when it is there.
class AnchorPoses {
 public:
  virtual ~AnchorPoses() = default;
  [[nodiscard]] virtual Eigen::Isometry3d anchorCameraPose(const Landmark& l) const = 0;
};

/// This frame's hits and misses, per slot (arrays of the tracker, valid during scoreFrame).
struct FrameOutcome {
  const std::vector<Prediction>* predictions = nullptr;
  const uint8_t* associated = nullptr;    // a hypothesis fell into the gate and was taken
  const uint8_t* contradicted = nullptr;  // ... but the policy refused it (onAssociation false)
  const uint8_t* probed = nullptr;        // found by the re-measurement: neither hit nor miss
};

/// A candidate being created from hypothesis `h` of salient point `point`.
struct SeedInfo {
  const SalientPoint* point = nullptr;
  const StereoHypotheses* hypotheses = nullptr;
  const DisparityHypothesis* h = nullptr;
  /// Candidates created from this point (its rivals and itself) [-], at most 8.
  int rivals = 1;
  /// This hypothesis' weight (2 when left-right consistent, else 1) and the sum over the rivals.
  double weight = 1.0;
  double weight_sum = 1.0;
  /// Depth of the triangulated hypothesis in the left camera [m].
  double z_cl_m = 0.0;
};

class ConfirmationPolicy {
 public:
  enum class Decision { kKeep, kConfirm, kPrune };

  virtual ~ConfirmationPolicy() = default;

  // ---- what the tracker asks before it acts ---------------------------------------------------
  /// A confirmed landmark whose gate holds more than one corner is not associated.
  [[nodiscard]] virtual bool rejectsAmbiguousConfirmedHits() const { return false; }
  /// Unassociated candidates are re-measured at their predicted pixel (the probe step).
  [[nodiscard]] virtual bool probesUnseen() const { return false; }
  /// A probe's single answer in the gate counts (neither hit nor miss) only when this holds.
  [[nodiscard]] virtual bool acceptsProbeAnswer(const DisparityHypothesis& /*h*/) const {
    return true;
  }
  /// Whether a hypothesis (already in front of min_depth_m) may seed a candidate.
  [[nodiscard]] virtual bool seeds(const DisparityHypothesis& /*h*/) const { return true; }
  /// Whether `h` is the same answer as one of the `n` hypotheses already chosen for its point
  /// (then it is not seeded).
  [[nodiscard]] virtual bool sameAnswerAsChosen(const StereoHypotheses& /*hyps*/,
                                                const uint32_t* /*chosen*/,
                                                int /*n*/,
                                                const DisparityHypothesis& /*h*/) const {
    return false;
  }
  /// A new candidate is confirmed at once.
  [[nodiscard]] virtual bool confirmsAtSeed() const { return false; }

  // ---- slots ----------------------------------------------------------------------------------
  /// Slot (re)used for a new landmark: reset its state (grow the state arrays as needed).
  virtual void onAllocate(uint32_t slot) = 0;
  /// Slot freed (pruned, retired, capped or a rival of a confirmed landmark).
  virtual void onRelease(uint32_t /*slot*/, const Landmark& /*l*/) {}

  // ---- one frame ------------------------------------------------------------------------------
  virtual void beginFrame(size_t /*num_slots*/) {}
  /// Hypothesis h at corner c was associated with the landmark in `slot` (before the tracker
  /// records it). Returns false to refuse it: a contradiction, counted as a miss and not
  /// recorded.
  virtual bool onAssociation(uint32_t /*slot*/,
                             const Landmark& /*l*/,
                             const DisparityHypothesis& /*h*/,
                             const Corner& /*c*/,
                             const FrameContext& /*frame*/,
                             const AnchorPoses& /*anchors*/) {
    return true;
  }
  /// After the tracker recorded an association: the measurement triangulated to p_cl (left
  /// camera) and l.p_w_last.
  virtual void onMeasured(uint32_t /*slot*/,
                          const Landmark& /*l*/,
                          const Eigen::Vector3d& /*p_cl*/) {}
  /// Evidence from this frame's hits and misses.
  virtual void scoreFrame(const FrameOutcome& /*outcome*/,
                          const FrameContext& /*frame*/,
                          std::vector<Landmark>* /*slots*/) {}
  /// Confirm, prune or keep a live candidate (may update its confidence).
  virtual Decision decide(uint32_t slot, Landmark* l, const FrameContext& frame) = 0;
  /// Candidates to release because `slot` is being confirmed (at most one of them is real).
  virtual void rivalsToRetire(uint32_t /*slot*/, std::vector<uint32_t>* out) { out->clear(); }
  /// After the rivals were released, before the tracker marks `slot` confirmed.
  virtual void onConfirmed(uint32_t /*slot*/) {}

  // ---- seeding --------------------------------------------------------------------------------
  /// A salient point is about to seed `n` candidates (its rivals).
  virtual void beginSeedGroup(int /*n*/) {}
  /// A candidate was created in `slot` (tracker fields set); set its confidence and state.
  virtual void onSeed(uint32_t slot, Landmark* l, const SeedInfo& seed, const FrameContext& f) = 0;
};

/// The policy named by options.policy, with its options group.
std::unique_ptr<ConfirmationPolicy> makeConfirmationPolicy(const StereoRig& rig,
                                                           const LandmarkOptions& options);

}  // namespace twocam::landmarks
