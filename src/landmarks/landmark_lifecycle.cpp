#include <algorithm>
#include <cmath>
#include <limits>

#include "landmarks/landmark_database.h"
#include "landmarks/landmark_model.h"
#include "landmarks/refine.h"

// The landmark life cycle of LandmarkDatabase: slots, scoring through the confirmation policy,
// confirmation with refinement and fusion of a corner's second track, seeding, restoring a
// saved map's landmarks and the caps. Prediction, gating and association are in
// landmark_database.cpp.

namespace twocam::landmarks {

uint32_t LandmarkDatabase::allocateSlot() {
  uint32_t slot;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<uint32_t>(slots_.size());
    slots_.emplace_back();
    hot_.emplace_back();
  }
  hot_[slot] = HotSlot();
  Landmark& l = slots_[slot];
  std::vector<Observation> keep = std::move(l.observations);  // keeps its capacity
  keep.clear();
  l = Landmark();
  l.observations = std::move(keep);
  l.id = next_id_++;
  slot_of_id_.insert(l.id, slot);
  policy_->onAllocate(slot);
  return slot;
}

void LandmarkDatabase::releaseSlot(uint32_t slot, FrameReport* report) {
  Landmark& l = slots_[slot];
  if (l.state == LandmarkState::kFree) return;
  policy_->onRelease(slot, l);
  if (l.state == LandmarkState::kCandidate) --num_candidates_;
  if (l.state == LandmarkState::kConfirmed) --num_confirmed_;
  l.state = LandmarkState::kFree;
  hot_[slot].state = LandmarkState::kFree;
  l.observations.clear();
  slot_of_id_.erase(l.id);
  free_slots_.push_back(slot);
  if (report != nullptr) {
    report->removed_ids.push_back(l.id);
    ++report->pruned;
  }
}

void LandmarkDatabase::scoreAndLifeCycle(FrameReport* report) {
  // 1. Misses of this frame's predicted visible landmarks; the policy turns hits and misses
  // into evidence.
  for (const Prediction& p : predictions_) {
    // Found by the probe at the predicted depth: neither seen nor missed (probe_unseen).
    if (probed_[p.slot]) continue;
    if (associated_[p.slot] == 0 || contradicted_[p.slot]) ++slots_[p.slot].consecutive_misses;
  }
  FrameOutcome outcome;
  outcome.predictions = &predictions_;
  outcome.associated = associated_.data();
  outcome.contradicted = contradicted_.data();
  outcome.probed = probed_.data();
  policy_->scoreFrame(outcome, frame_ctx_, &slots_);

  // 2. Life cycle, then the policy's rule for the candidates that are still live.
  for (uint32_t s = 0; s < slots_.size(); ++s) {
    // A confirmed landmark's misses change only when it is predicted visible.
    const LandmarkState state = hot_[s].state;
    if (state == LandmarkState::kFree || (state == LandmarkState::kConfirmed && !visible_[s]))
      continue;
    Landmark& l = slots_[s];
    if (l.state == LandmarkState::kConfirmed) {
      if (l.consecutive_misses > options_.tracker.max_confirmed_misses) releaseSlot(s, report);
      continue;
    }
    if (l.state != LandmarkState::kCandidate) continue;
    if (l.frames_out_of_view > options_.tracker.max_frames_out_of_view ||
        l.consecutive_misses > options_.tracker.max_consecutive_misses) {
      releaseSlot(s, report);
      continue;
    }
    switch (policy_->decide(s, &l, frame_ctx_)) {
      case ConfirmationPolicy::Decision::kPrune:
        releaseSlot(s, report);
        break;
      case ConfirmationPolicy::Decision::kConfirm:
        confirm(s, report);
        break;
      case ConfirmationPolicy::Decision::kKeep:
        break;
    }
  }
}

bool LandmarkDatabase::projectForFusion(uint32_t slot, Eigen::Vector3d* uvd) const {
  const Eigen::Vector3d p_cl = T_cl_w_ * hot_[slot].p_w_last;
  return p_cl.z() >= options_.tracker.min_depth_m && projectStereo(rig_, p_cl, uvd);
}

int64_t LandmarkDatabase::fusionKey(int64_t cu, int64_t cv) {
  return static_cast<int64_t>((static_cast<uint64_t>(cv) << 32) ^
                              (static_cast<uint64_t>(cu) & 0xFFFFFFFFu));
}

void LandmarkDatabase::addToFusionIndex(uint32_t slot, double sigma_u_px, double sigma_v_px) {
  Eigen::Vector3d uvd;
  if (!projectForFusion(slot, &uvd)) return;
  // The chance that the landmark's own corner lies within the fusion radius of its prediction
  // (Gaussian prediction error), against the chance that some other corner does (this frame's
  // corner density over the radius' square).
  const double r = options_.tracker.fuse_radius_px;
  const double p_own =
      std::erf(r / (std::sqrt(2.0) * sigma_u_px)) * std::erf(r / (std::sqrt(2.0) * sigma_v_px));
  const double p_other = std::min(1.0, corner_density_ * 4.0 * r * r);
  if (p_own < kFusionMinLikelihoodRatio * p_other) return;
  fusion_index_[fusionKey(static_cast<int64_t>(std::floor(uvd.x() / kFusionCellPx)),
                          static_cast<int64_t>(std::floor(uvd.y() / kFusionCellPx)))]
      .push_back({slot,
                  static_cast<float>(uvd.x()),
                  static_cast<float>(uvd.y()),
                  static_cast<float>(uvd.z())});
}

void LandmarkDatabase::buildFusionIndex() {
  if (fusion_index_built_) return;
  fusion_index_built_ = true;
  fusion_index_.clear();
  for (size_t i = 0; i < predictions_.size(); ++i) {
    const Prediction& p = predictions_[i];
    if (hot_[p.slot].state != LandmarkState::kConfirmed) continue;
    const float inv_var_u = has_tight_gates_ ? tight_gates_[i].inv_var_u : p.inv_var_u;
    const float inv_var_v = has_tight_gates_ ? tight_gates_[i].inv_var_v : p.inv_var_v;
    addToFusionIndex(p.slot, 1.0 / std::sqrt(inv_var_u), 1.0 / std::sqrt(inv_var_v));
  }
}

int64_t LandmarkDatabase::nearestConfirmed(const Eigen::Vector3d& uvd,
                                           int64_t exclude_slot,
                                           bool unassociated_only) {
  buildFusionIndex();
  const double r = options_.tracker.fuse_radius_px;
  const double rd = options_.tracker.fuse_disparity_px;
  int64_t best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  const int64_t cu0 = static_cast<int64_t>(std::floor((uvd.x() - r) / kFusionCellPx));
  const int64_t cu1 = static_cast<int64_t>(std::floor((uvd.x() + r) / kFusionCellPx));
  const int64_t cv0 = static_cast<int64_t>(std::floor((uvd.y() - r) / kFusionCellPx));
  const int64_t cv1 = static_cast<int64_t>(std::floor((uvd.y() + r) / kFusionCellPx));
  for (int64_t cv = cv0; cv <= cv1; ++cv) {
    for (int64_t cu = cu0; cu <= cu1; ++cu) {
      const auto it = fusion_index_.find(fusionKey(cu, cv));
      if (it == fusion_index_.end()) continue;
      for (const FusionEntry& e : it->second) {
        if (static_cast<int64_t>(e.slot) == exclude_slot ||
            hot_[e.slot].state != LandmarkState::kConfirmed)
          continue;
        // Reclaiming takes landmarks confirmed before this frame and not associated in it (a
        // slot seeded this frame lies beyond the per-frame flags).
        if (unassociated_only &&
            (e.slot >= associated_.size() || associated_[e.slot] || contradicted_[e.slot] ||
             slots_[e.slot].confirmed_frame >= frame_))
          continue;
        const double du = e.u - uvd.x(), dv = e.v - uvd.y(), dd = e.d - uvd.z();
        if (std::abs(du) > r || std::abs(dv) > r || std::abs(dd) > rd) continue;
        const double d2 = du * du + dv * dv + dd * dd;
        if (d2 < best_d2) {
          best_d2 = d2;
          best = e.slot;
        }
      }
    }
  }
  return best;
}

int64_t LandmarkDatabase::findFusionPartner(uint32_t slot) {
  Eigen::Vector3d uvd;
  if (!projectForFusion(slot, &uvd)) return -1;
  return nearestConfirmed(uvd, slot, false);
}

bool LandmarkDatabase::reclaimByConfirmed(const SalientPoint& point,
                                          const StereoHypotheses& hyps,
                                          FrameReport* report) {
  for (uint32_t k = 0; k < point.num_hypotheses; ++k) {
    const uint32_t j = point.first_hypothesis + k;
    const DisparityHypothesis& h = hyps.hypotheses[j];
    const int64_t target =
        nearestConfirmed(Eigen::Vector3d(point.corner.u_px, point.corner.v_px, h.d_px), -1, true);
    if (target < 0) continue;
    const auto slot = static_cast<uint32_t>(target);
    associated_[slot] = 1;
    if (!applyObservation(slot, h, point.corner)) return true;  // refused: still not seeded
    report->hypothesis_landmark_id[j] = slots_[slot].id;
    report->associated_ids.push_back(slots_[slot].id);
    ++report->associated;
    ++report->reclaimed;
    return true;
  }
  return false;
}

void LandmarkDatabase::fuseInto(uint32_t candidate, uint32_t target, FrameReport* report) {
  Landmark& c = slots_[candidate];
  Landmark& t = slots_[target];
  // Slots allocated this frame lie beyond the per-frame flags: seeded here, so measured here.
  const auto seen_now = [&](uint32_t s) {
    return s >= associated_.size() || (associated_[s] != 0 && contradicted_[s] == 0);
  };
  if ((seen_now(candidate) || c.first_frame == frame_) && !seen_now(target)) {
    // The candidate's measurement of this frame is the confirmed landmark's.
    associated_[target] = 1;
    t.consecutive_misses = 0;
    t.last_seen_frame = frame_;
    t.path_at_last_seen_m = path_m_;
    t.turn_at_last_seen_rad = turn_rad_;
    ++t.n_obs;
    report->associated_ids.push_back(t.id);
    for (uint64_t& id : report->hypothesis_landmark_id) {
      if (id == c.id) id = t.id;
    }
  }
  ++report->fused;
  report->fused_ids.emplace_back(c.id, t.id);
  releaseSlot(candidate, report);
}

void LandmarkDatabase::confirm(uint32_t slot, FrameReport* report) {
  Landmark& l = slots_[slot];
  policy_->rivalsToRetire(slot, &rivals_);
  for (uint32_t r : rivals_) {
    if (slots_[r].state == LandmarkState::kCandidate) releaseSlot(r, report);
  }
  bool refined = false;
  if (options_.refine.enabled && l.observations.size() >= 2) {
    RefineOptions ro;
    ro.disparity_sigma_px = options_.tracker.disparity_sigma_px;
    ro.huber = options_.refine.huber;
    ro.noise_model = options_.tracker;
    refined = refineLandmark(rig_, T_b_cl_, l.observations, ro, &l.p_w) == RefineResult::kOk;
  }
  if (options_.tracker.fuse_radius_px > 0.0) {
    const int64_t partner = findFusionPartner(slot);
    if (partner >= 0) {
      fuseInto(slot, static_cast<uint32_t>(partner), report);
      return;
    }
  }
  report->refined += refined ? 1 : 0;
  policy_->onConfirmed(slot);
  l.state = LandmarkState::kConfirmed;
  hot_[slot].state = LandmarkState::kConfirmed;
  l.confirmed_frame = frame_;
  --num_candidates_;
  ++num_confirmed_;
  ++report->confirmed;
  report->confirmed_ids.push_back(l.id);
  // Confirmed landmarks are not re-refined (see RefinementOptions::enabled), so their observations
  // are not needed any more: about 1 kB per landmark, and no per-hit copying.
  std::vector<Observation>().swap(l.observations);
  if (map_frame_predictions_) {
    l.p_w_last = l.p_w;
    hot_[slot].p_w_last = l.p_w;
  }
  // Just measured: its prediction error in this frame is the corner noise.
  if (fusion_index_built_) {
    addToFusionIndex(slot, options_.tracker.pixel_sigma_px, options_.tracker.pixel_sigma_px);
  }
}

void LandmarkDatabase::restoreConfirmed(const std::vector<Eigen::Vector3d>& p_w,
                                        std::vector<uint64_t>* ids) {
  TWOCAM_CHECK(frame_hyps_ == nullptr) << "restoreConfirmed inside a frame";
  for (const Eigen::Vector3d& p : p_w) {
    if (!p.allFinite()) continue;
    const uint32_t slot = allocateSlot();
    Landmark& l = slots_[slot];
    l.state = LandmarkState::kConfirmed;
    hot_[slot].state = LandmarkState::kConfirmed;
    l.p_w = l.p_w_last = p;
    hot_[slot].p_w_last = p;
    Eigen::Vector3d uvd = Eigen::Vector3d::Zero();
    if (!projectStereo(rig_, T_cl_w_ * p, &uvd)) uvd.setZero();
    l.anchor.frame = frame_;
    l.anchor.u_px = static_cast<float>(uvd.x());
    l.anchor.v_px = static_cast<float>(uvd.y());
    l.anchor.d_px = static_cast<float>(uvd.z());
    l.anchor.odom_pose = pose_;
    l.first_frame = l.confirmed_frame = l.last_seen_frame = l.last_visible_frame = frame_;
    l.first_t_ns = t_ns_;
    l.path_at_last_seen_m = path_m_;
    l.turn_at_last_seen_rad = turn_rad_;
    l.confidence = 1.0f;
    policy_->onConfirmed(slot);
    ++num_confirmed_;
    if (ids != nullptr) ids->push_back(l.id);
  }
}

int LandmarkDatabase::pageOut(const std::vector<uint64_t>& ids) {
  TWOCAM_CHECK(frame_hyps_ == nullptr) << "pageOut inside a frame";
  int left = 0;
  for (uint64_t id : ids) {
    const uint32_t slot = slot_of_id_.find(id);
    if (slot == IdIndex::kNone || slots_[slot].state != LandmarkState::kConfirmed) continue;
    releaseSlot(slot, nullptr);
    ++left;
  }
  return left;
}

void LandmarkDatabase::seed(const StereoHypotheses& hyps, FrameReport* report) {
  const double fb = rig_.fx_px * rig_.baseline_m;
  for (uint32_t pi = 0; pi < hyps.points.size(); ++pi) {
    const SalientPoint& point = hyps.points[pi];
    if (point.num_hypotheses == 0) continue;
    bool explained = false;
    for (uint32_t k = 0; k < point.num_hypotheses; ++k) {
      if (report->hypothesis_landmark_id[point.first_hypothesis + k] != 0) explained = true;
    }
    if (explained) continue;  // tracked by an existing landmark: not seeded again
    // A confirmed landmark predicted on this corner (within the fusion radius) that was not
    // associated (its gate held several corners) takes it: the map already has this point.
    if (options_.tracker.fuse_radius_px > 0.0 && reclaimByConfirmed(point, hyps, report)) continue;
    if (!options_.tracker.seed_depth_edges &&
        hyps.hypotheses[point.first_hypothesis].window_shift_px != 0) {
      continue;  // best match from a shifted window: the corner is on a depth edge
    }
    uint32_t chosen[kMaxRivals];
    int n = 0;
    for (uint32_t k = 0; k < point.num_hypotheses && n < kMaxRivals; ++k) {
      const uint32_t j = point.first_hypothesis + k;
      const DisparityHypothesis& h = hyps.hypotheses[j];
      if (!(h.d_px > 0.0f) || fb / h.d_px < options_.tracker.min_depth_m) continue;
      if (!policy_->seeds(h) || policy_->sameAnswerAsChosen(hyps, chosen, n, h)) continue;
      chosen[n++] = j;
    }
    if (n == 0) continue;
    double weight_sum = 0.0;
    for (int i = 0; i < n; ++i) weight_sum += hyps.hypotheses[chosen[i]].lr_consistent ? 2.0 : 1.0;
    policy_->beginSeedGroup(n);
    for (int i = 0; i < n; ++i) {
      const DisparityHypothesis& h = hyps.hypotheses[chosen[i]];
      const auto p_cl =
          triangulateRectified(rig_, Eigen::Vector2d(point.corner.u_px, point.corner.v_px), h.d_px);
      const uint32_t slot = allocateSlot();
      Landmark& l = slots_[slot];
      l.state = LandmarkState::kCandidate;
      hot_[slot].state = LandmarkState::kCandidate;
      ++num_candidates_;
      l.p_w = T_w_cl_ * *p_cl;
      l.p_w_last = l.p_w;
      hot_[slot].p_w_last = l.p_w;
      l.anchor.frame = frame_;
      l.anchor.u_px = static_cast<float>(point.corner.u_px);
      l.anchor.v_px = static_cast<float>(point.corner.v_px);
      l.anchor.d_px = h.d_px;
      l.anchor.odom_pose = pose_;
      l.observations.push_back(l.anchor);
      l.first_frame = l.last_seen_frame = frame_;
      l.first_t_ns = t_ns_;
      l.path_at_last_seen_m = path_m_;
      l.turn_at_last_seen_rad = turn_rad_;
      l.n_obs = 1;
      l.n_visible = 1;
      SeedInfo info;
      info.point = &point;
      info.hypotheses = &hyps;
      info.h = &h;
      info.rivals = n;
      info.weight = h.lr_consistent ? 2.0 : 1.0;
      info.weight_sum = weight_sum;
      info.z_cl_m = p_cl->z();
      policy_->onSeed(slot, &l, info, frame_ctx_);
      report->hypothesis_landmark_id[chosen[i]] = l.id;
      report->created_ids.push_back(l.id);
      report->created_hypotheses.push_back(chosen[i]);
      ++report->seeded;
      if (policy_->confirmsAtSeed()) confirm(slot, report);
    }
  }
}

void LandmarkDatabase::enforceCaps(FrameReport* report) {
  if (num_confirmed_ > options_.tracker.max_confirmed) {
    std::vector<std::pair<int32_t, uint32_t>> order;  // (last seen frame, slot)
    order.reserve(static_cast<size_t>(num_confirmed_));
    for (uint32_t s = 0; s < slots_.size(); ++s) {
      if (slots_[s].state == LandmarkState::kConfirmed)
        order.emplace_back(slots_[s].last_seen_frame, s);
    }
    const size_t excess = order.size() - static_cast<size_t>(options_.tracker.max_confirmed);
    std::nth_element(
        order.begin(), order.begin() + static_cast<std::ptrdiff_t>(excess), order.end());
    for (size_t i = 0; i < excess; ++i) releaseSlot(order[i].second, report);
  }
  if (num_candidates_ <= options_.tracker.max_candidates) return;
  std::vector<std::pair<float, uint32_t>> order;
  order.reserve(static_cast<size_t>(num_candidates_));
  for (uint32_t s = 0; s < slots_.size(); ++s) {
    if (slots_[s].state == LandmarkState::kCandidate) order.emplace_back(slots_[s].confidence, s);
  }
  const size_t excess = order.size() - static_cast<size_t>(options_.tracker.max_candidates);
  std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(excess), order.end());
  for (size_t i = 0; i < excess; ++i) releaseSlot(order[i].second, report);
}

}  // namespace twocam::landmarks
