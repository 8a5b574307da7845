#include "landmarks/baseline_policies.h"

#include <algorithm>
#include <cmath>

#include "landmarks/landmark_model.h"

namespace twocam::landmarks {

void BaselinePolicy::onSeed(uint32_t /*slot*/,
                            Landmark* l,
                            const SeedInfo& seed,
                            const FrameContext& /*f*/) {
  // As 1 - (1 - p), the form the consistency prior is computed in (the same bits for 0.5).
  const double prior_real = 1.0 - (1.0 - kBaselineSeedPrior);
  l->confidence = static_cast<float>(prior_real * seed.weight / seed.weight_sum);
}

ConfirmationPolicy::Decision SeenCountPolicy::decide(uint32_t /*slot*/,
                                                     Landmark* l,
                                                     const FrameContext& f) {
  const double t_s = static_cast<double>(f.t_ns) * 1e-9;
  const double age_s = t_s - static_cast<double>(l->first_t_ns) * 1e-9;
  l->confidence =
      std::min(1.0f, static_cast<float>(l->n_obs) / static_cast<float>(options_.min_observations));
  if (l->n_obs >= options_.min_observations && age_s <= options_.window_s)
    return Decision::kConfirm;
  if (age_s > options_.window_s) return Decision::kPrune;
  return Decision::kKeep;
}

ConfirmationPolicy::Decision CullingPolicy::decide(uint32_t /*slot*/,
                                                   Landmark* l,
                                                   const FrameContext& f) {
  const float ratio = static_cast<float>(l->n_obs) / static_cast<float>(std::max(1, l->n_visible));
  l->confidence = std::min(1.0f, ratio);
  if (f.frame - l->first_frame < options_.decision_frames) return Decision::kKeep;
  if (ratio >= options_.min_found_ratio && l->n_obs >= options_.min_observations) {
    return Decision::kConfirm;
  }
  return Decision::kPrune;
}

InlierRatioPolicy::InlierRatioPolicy(const StereoRig& rig, const LandmarkOptions& options)
    : rig_(rig),
      T_b_cl_(rig.T_b_cl),
      min_depth_m_(options.tracker.min_depth_m),
      disparity_sigma_px_(options.tracker.disparity_sigma_px),
      options_(options.inlier_ratio) {}

void InlierRatioPolicy::onAllocate(uint32_t slot) {
  if (slot >= state_.size()) state_.resize(slot + 1);
  state_[slot] = State();
}

void InlierRatioPolicy::onSeed(uint32_t slot,
                               Landmark* l,
                               const SeedInfo& seed,
                               const FrameContext& f) {
  BaselinePolicy::onSeed(slot, l, seed, f);
  State& st = state_[slot];
  st.range = static_cast<float>(1.0 / min_depth_m_);
  st.mu = static_cast<float>(1.0 / seed.z_cl_m);
  st.sigma2 = st.range * st.range / 36.0f;
}

void InlierRatioPolicy::onMeasured(uint32_t slot, const Landmark& l, const Eigen::Vector3d& p_cl) {
  if (l.state != LandmarkState::kCandidate) return;
  // The measurement as an inverse depth along the anchor ray (SVO's seed parametrisation).
  const Eigen::Vector3d p_anchor =
      cameraPoseInWorld(l.anchor.odom_pose, T_b_cl_).inverse() * l.p_w_last;
  if (!(p_anchor.z() > min_depth_m_)) return;
  State& st = state_[slot];
  const double fb = rig_.fx_px * rig_.baseline_m;
  const double ratio = p_cl.z() / p_anchor.z();
  const double tau = ratio * ratio * disparity_sigma_px_ / fb;
  SvoSeed seed{st.mu, st.sigma2, st.a, st.b, st.range};
  if (updateSvoSeed(1.0 / p_anchor.z(), tau * tau, &seed)) {
    st.mu = static_cast<float>(seed.mu);
    st.sigma2 = static_cast<float>(seed.sigma2);
    st.a = static_cast<float>(seed.a);
    st.b = static_cast<float>(seed.b);
  }
}

ConfirmationPolicy::Decision InlierRatioPolicy::decide(uint32_t slot,
                                                       Landmark* l,
                                                       const FrameContext& /*f*/) {
  const State& st = state_[slot];
  const float ratio = st.a / (st.a + st.b);
  l->confidence = ratio;
  if (ratio < options_.prune_inlier_ratio) return Decision::kPrune;
  if (std::sqrt(st.sigma2) < options_.converged_sigma_fraction * st.range &&
      ratio >= options_.min_inlier_ratio) {
    return Decision::kConfirm;
  }
  return Decision::kKeep;
}

}  // namespace twocam::landmarks
