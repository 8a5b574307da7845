#pragma once
/// The `consistency` policy, TwoCam's own (docs/landmarks.md): a candidate's existence is a
/// log-odds evidence sum over its hits and misses, counted only when the odometry says the
/// robot moved; a re-observation is first checked against the candidate's anchor (the anchor's
/// triangulation moved by the odometry must predict it), and the candidates seeded from one
/// corner's hypotheses are rivals (at most one is real) whose probabilities are normalised
/// together. A candidate with rivals is confirmed only once its re-observations tell it from a
/// periodic-texture phantom (verification), after some parallax and with row support.
/// Options: ConsistencyOptions (landmarks.consistency).

#include <vector>

#include "landmarks/confirmation_policy.h"

namespace twocam::landmarks {

class ConsistencyPolicy final : public ConfirmationPolicy {
 public:
  ConsistencyPolicy(const StereoRig& rig, const LandmarkOptions& options);

  /// Per-landmark state of the policy (indexed by the tracker's slot).
  struct State {
    /// Odometry path length when evidence was last counted, and path and turn at the anchor
    /// [m], [rad].
    double path_at_last_evidence_m = 0.0;
    double path_at_anchor_m = 0.0;
    double turn_at_anchor_rad = 0.0;
    /// Rival group (hypotheses of the same corner in the creating frame; 0 = none, else the
    /// group's index + 1) and this member's prior.
    uint32_t group = 0;
    float prior = 0.0f;
    /// Accumulated evidence log-likelihood ratio [nats].
    float evidence = 0.0f;
    /// Largest parallax of a consistent re-observation so far, the angle at the anchor point
    /// between the anchor's and the observation's left-camera centres [rad]; no longer updated
    /// once it reaches ConsistencyOptions::min_parallax_deg.
    float max_parallax_rad = 0.0f;
    /// AnchorCheck::phantom_llr summed over the consistent re-observations, for the phantom
    /// below and above the anchor disparity [nats].
    float phantom_llr[2] = {0.0f, 0.0f};
    /// Complete hypothesis lists (ConsistencyOptions::verify_own_rivals): the disparities of
    /// the nearest rival below and above the anchor's [px], the real points those phantoms
    /// stand for; 0 = no rival on that side. Unused (own_phantoms false) otherwise.
    float phantom_d_px[2] = {0.0f, 0.0f};
    /// Observations (anchor included) whose hypothesis lacked row support (see
    /// ConsistencyOptions::max_row_span_px).
    int32_t n_row_unsupported = 0;
    /// Number of hypotheses of the corner when the candidate was created (1 = no rivals).
    uint8_t rivals_at_creation = 1;
    /// The consistent re-observations favour this candidate over the phantoms of a rival depth
    /// by at least ConsistencyOptions::verify_llr.
    bool verified = false;
    bool own_phantoms = false;
  };
  [[nodiscard]] const State& state(uint32_t slot) const { return state_[slot]; }

  [[nodiscard]] bool rejectsAmbiguousConfirmedHits() const override {
    return options_.unambiguous_confirmed_hits;
  }
  [[nodiscard]] bool probesUnseen() const override { return options_.probe_unseen; }
  [[nodiscard]] bool acceptsProbeAnswer(const DisparityHypothesis& h) const override {
    return rowSupported(h);
  }
  [[nodiscard]] bool sameAnswerAsChosen(const StereoHypotheses& hyps,
                                        const uint32_t* chosen,
                                        int n,
                                        const DisparityHypothesis& h) const override;

  void onAllocate(uint32_t slot) override;
  void onRelease(uint32_t slot, const Landmark& l) override;
  void beginFrame(size_t num_slots) override;
  bool onAssociation(uint32_t slot,
                     const Landmark& l,
                     const DisparityHypothesis& h,
                     const Corner& c,
                     const FrameContext& frame,
                     const AnchorPoses& anchors) override;
  void scoreFrame(const FrameOutcome& outcome,
                  const FrameContext& frame,
                  std::vector<Landmark>* slots) override;
  Decision decide(uint32_t slot, Landmark* l, const FrameContext& frame) override;
  void rivalsToRetire(uint32_t slot, std::vector<uint32_t>* out) override;
  void onConfirmed(uint32_t slot) override;
  void beginSeedGroup(int n) override;
  void onSeed(uint32_t slot, Landmark* l, const SeedInfo& seed, const FrameContext& f) override;

  /// Row support of a hypothesis: its row_span_px is at most
  /// max(max_row_span_px, max_row_span_relative * d).
  [[nodiscard]] bool rowSupported(const DisparityHypothesis& h) const;

 private:
  struct RivalGroup {
    static constexpr int kMaxMembers = 8;
    uint32_t members[kMaxMembers] = {};
    uint8_t count = 0;
    /// Mass of members that left the group (pi_j exp(L_j)) and of "none is real".
    double removed_mass = 0.0;
    double none_mass = 0.0;
  };

  /// Prior mass of "none of a point's hypotheses is real": 1 - prior_real.
  [[nodiscard]] double noneMass() const { return 1.0 - options_.prior_real; }
  void removeFromGroup(uint32_t slot);
  void normaliseGroup(uint32_t group, std::vector<Landmark>* slots);

  StereoRig rig_;
  LandmarkOptions all_options_;  // checkAgainstAnchor reads the tracker's sigmas too
  ConsistencyOptions options_;
  float min_parallax_rad_;  // options_.min_parallax_deg in radians
  std::vector<State> state_;
  std::vector<RivalGroup> groups_;
  std::vector<uint32_t> free_groups_;
  uint32_t seed_group_ = 0;           // the group being seeded (index + 1)
  std::vector<uint8_t> informative_;  // per slot, this frame: the motion exposes depth
  std::vector<uint32_t> groups_touched_;
  std::vector<uint8_t> group_touched_flag_;
};

}  // namespace twocam::landmarks
