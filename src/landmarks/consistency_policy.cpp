#include "landmarks/consistency_policy.h"

#include <algorithm>
#include <cmath>

#include "landmarks/landmark_model.h"

namespace twocam::landmarks {

ConsistencyPolicy::ConsistencyPolicy(const StereoRig& rig, const LandmarkOptions& options)
    : rig_(rig),
      all_options_(options),
      options_(options.consistency),
      min_parallax_rad_(static_cast<float>(options.consistency.min_parallax_deg * M_PI / 180.0)) {}

bool ConsistencyPolicy::rowSupported(const DisparityHypothesis& h) const {
  return h.row_span_px <=
         std::max(options_.max_row_span_px, options_.max_row_span_relative * h.d_px);
}

bool ConsistencyPolicy::sameAnswerAsChosen(const StereoHypotheses& hyps,
                                           const uint32_t* chosen,
                                           int n,
                                           const DisparityHypothesis& h) const {
  // A cheaper hypothesis within same_answer_px stands for this one: the same answer, which as a
  // rival would take half the belief and never be told apart by motion.
  bool twin = false;
  for (int i = 0; i < n; ++i) {
    twin = twin || std::abs(hyps.hypotheses[chosen[i]].d_px - h.d_px) <= options_.same_answer_px;
  }
  return twin;
}

void ConsistencyPolicy::onAllocate(uint32_t slot) {
  if (slot >= state_.size()) state_.resize(slot + 1);
  state_[slot] = State();
}

void ConsistencyPolicy::onRelease(uint32_t slot, const Landmark& /*l*/) { removeFromGroup(slot); }

void ConsistencyPolicy::removeFromGroup(uint32_t slot) {
  State& st = state_[slot];
  if (st.group == 0) return;  // group index 0 means "none"; real groups are stored at g + 1
  RivalGroup& g = groups_[st.group - 1];
  for (int i = 0; i < g.count; ++i) {
    if (g.members[i] == slot) {
      g.removed_mass += static_cast<double>(st.prior) * std::exp(static_cast<double>(st.evidence));
      g.members[i] = g.members[g.count - 1];
      --g.count;
      break;
    }
  }
  if (g.count == 0) free_groups_.push_back(st.group - 1);
  st.group = 0;
}

void ConsistencyPolicy::normaliseGroup(uint32_t group, std::vector<Landmark>* slots) {
  const RivalGroup& g = groups_[group];
  double prior[RivalGroup::kMaxMembers];
  double evidence[RivalGroup::kMaxMembers];
  double prob[RivalGroup::kMaxMembers];
  for (int i = 0; i < g.count; ++i) {
    prior[i] = state_[g.members[i]].prior;
    evidence[i] = state_[g.members[i]].evidence;
  }
  normaliseRivals(prior, evidence, g.count, g.none_mass, g.removed_mass, prob);
  for (int i = 0; i < g.count; ++i) (*slots)[g.members[i]].confidence = static_cast<float>(prob[i]);
}

void ConsistencyPolicy::beginFrame(size_t num_slots) { informative_.assign(num_slots, 0); }

bool ConsistencyPolicy::onAssociation(uint32_t slot,
                                      const Landmark& l,
                                      const DisparityHypothesis& h,
                                      const Corner& c,
                                      const FrameContext& frame,
                                      const AnchorPoses& anchors) {
  if (l.state != LandmarkState::kCandidate) return true;
  State& st = state_[slot];
  const Eigen::Isometry3d T_w_anchor = anchors.anchorCameraPose(l);
  const AnchorCheck check = checkAgainstAnchor(all_options_,
                                               rig_,
                                               T_w_anchor,
                                               l.anchor.u_px,
                                               l.anchor.v_px,
                                               l.anchor.d_px,
                                               frame.T_cl_w,
                                               c.u_px,
                                               c.v_px,
                                               h.d_px,
                                               frame.path_m - st.path_at_anchor_m,
                                               frame.turn_rad - st.turn_at_anchor_rad,
                                               st.own_phantoms ? st.phantom_d_px : nullptr);
  const bool consistent = check.valid && check.mahalanobis2 <= options_.anchor_gate_chi2;
  informative_[slot] = check.discriminative ? 1 : 0;
  // A contradiction is evidence against the candidate, but not an observation of it: the track
  // stays where the anchor says it should be, so a spurious candidate cannot hop onto other
  // points.
  if (!consistent) return false;
  // Verification: the consistent re-observations together favour this candidate over either
  // phantom by verify_llr (docs/landmarks.md, "Verification").
  for (int k = 0; k < 2; ++k) {
    st.phantom_llr[k] = static_cast<float>(std::min(
        kPhantomImpossible, static_cast<double>(st.phantom_llr[k]) + check.phantom_llr[k]));
  }
  if (std::min(st.phantom_llr[0], st.phantom_llr[1]) >= options_.verify_llr) st.verified = true;
  if (st.max_parallax_rad < min_parallax_rad_) {  // only needed until the rule is met
    const double parallax =
        parallaxAngle(l.p_w, T_w_anchor.translation(), frame.T_w_cl.translation());
    st.max_parallax_rad = std::max(st.max_parallax_rad, static_cast<float>(parallax));
  }
  if (!rowSupported(h)) ++st.n_row_unsupported;
  return true;
}

void ConsistencyPolicy::scoreFrame(const FrameOutcome& outcome,
                                   const FrameContext& frame,
                                   std::vector<Landmark>* slots) {
  groups_touched_.clear();
  group_touched_flag_.resize(groups_.size(), 0);
  for (const Prediction& p : *outcome.predictions) {
    // Found by the probe at the predicted depth: neither seen nor missed (probe_unseen).
    if (outcome.probed[p.slot]) continue;
    Landmark& l = (*slots)[p.slot];
    State& st = state_[p.slot];
    const bool hit = outcome.associated[p.slot] != 0;
    if (frame.path_m - st.path_at_last_evidence_m < options_.evidence_step_m) continue;
    st.path_at_last_evidence_m = frame.path_m;
    if (!hit) {
      st.evidence +=
          static_cast<float>(missEvidence(options_.detection_prob, p.p_false_hit_per_hyp));
    } else if (outcome.contradicted[p.slot]) {
      st.evidence += static_cast<float>(options_.contradiction_evidence);
    } else if (informative_[p.slot] || l.state == LandmarkState::kConfirmed) {
      st.evidence += static_cast<float>(
          hitEvidence(options_.detection_prob, p.p_false_hit_per_hyp, options_.max_hit_evidence));
    } else {
      // Before the motion since its anchor could tell its depth from a rival's, a re-observation
      // only shows the corner is stable: a periodic-texture phantom reappears just the same.
      st.evidence += static_cast<float>(options_.stability_evidence);
    }
    if (st.group != 0 && !group_touched_flag_[st.group - 1]) {
      group_touched_flag_[st.group - 1] = 1;
      groups_touched_.push_back(st.group - 1);
    }
    if (st.group == 0) {
      // A confirmed landmark (no rivals left): plain log-odds with its prior.
      l.confidence =
          static_cast<float>(lonePosterior(st.prior, static_cast<double>(st.evidence), noneMass()));
    }
  }
  for (uint32_t g : groups_touched_) {
    group_touched_flag_[g] = 0;
    if (groups_[g].count > 0) normaliseGroup(g, slots);
  }
}

ConfirmationPolicy::Decision ConsistencyPolicy::decide(uint32_t slot,
                                                       Landmark* l,
                                                       const FrameContext& /*frame*/) {
  // The tracker record's fields first: most candidates are decided without their state.
  if (l->confidence < options_.prune_prob && state_[slot].path_at_last_evidence_m > 0.0) {
    return Decision::kPrune;
  }
  if (!(l->confidence >= options_.confirm_prob && l->n_obs >= options_.min_observations)) {
    return Decision::kKeep;
  }
  const State& st = state_[slot];
  const bool confirm = (st.verified || st.rivals_at_creation == 1) &&
                       st.max_parallax_rad >= min_parallax_rad_ &&
                       st.n_row_unsupported <= options_.max_row_unsupported_fraction * l->n_obs;
  return confirm ? Decision::kConfirm : Decision::kKeep;
}

void ConsistencyPolicy::rivalsToRetire(uint32_t slot, std::vector<uint32_t>* out) {
  out->clear();
  const State& st = state_[slot];
  if (st.group == 0) return;
  // At most one hypothesis of a corner is real: confirming one retires its rivals.
  const RivalGroup& g = groups_[st.group - 1];
  for (int i = 0; i < g.count; ++i) {
    if (g.members[i] != slot) out->push_back(g.members[i]);
  }
}

void ConsistencyPolicy::onConfirmed(uint32_t slot) { removeFromGroup(slot); }

void ConsistencyPolicy::beginSeedGroup(int /*n*/) {
  uint32_t g;
  if (!free_groups_.empty()) {
    g = free_groups_.back();
    free_groups_.pop_back();
    groups_[g] = RivalGroup();
  } else {
    groups_.emplace_back();
    g = static_cast<uint32_t>(groups_.size() - 1);
  }
  seed_group_ = g + 1;
  // Written as 1 - noneMass() (not prior_real) to keep the outputs of the time when a lone
  // point had its own prior bit for bit.
  const double prior_real = 1.0 - noneMass();
  groups_[g].none_mass = 1.0 - prior_real;
}

void ConsistencyPolicy::onSeed(uint32_t slot,
                               Landmark* l,
                               const SeedInfo& seed,
                               const FrameContext& f) {
  State& st = state_[slot];
  const DisparityHypothesis& h = *seed.h;
  const SalientPoint& point = *seed.point;
  st.path_at_last_evidence_m = st.path_at_anchor_m = f.path_m;
  st.turn_at_anchor_rad = f.turn_rad;
  st.n_row_unsupported = rowSupported(h) ? 0 : 1;
  st.rivals_at_creation = static_cast<uint8_t>(seed.rivals);
  st.own_phantoms = options_.verify_own_rivals && point.complete;
  if (st.own_phantoms) {
    // Every hypothesis of the corner is a possible real point, also those not seeded (too near,
    // or at zero disparity, whose phantom is then impossible); those within same_answer_px are
    // the candidate's own answer.
    const auto same = static_cast<float>(options_.same_answer_px);
    for (uint32_t k = 0; k < point.num_hypotheses; ++k) {
      const float d = seed.hypotheses->hypotheses[point.first_hypothesis + k].d_px;
      if (d < h.d_px - same && d > st.phantom_d_px[0]) st.phantom_d_px[0] = d;
      if (d > h.d_px + same && (st.phantom_d_px[1] == 0.0f || d < st.phantom_d_px[1])) {
        st.phantom_d_px[1] = d;
      }
    }
  }
  const double prior_real = 1.0 - noneMass();
  st.prior = static_cast<float>(prior_real * seed.weight / seed.weight_sum);
  l->confidence = st.prior;
  RivalGroup& group = groups_[seed_group_ - 1];
  group.members[group.count++] = slot;
  st.group = seed_group_;
}

}  // namespace twocam::landmarks
