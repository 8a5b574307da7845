#include "landmarks/options.h"

#include <cmath>
#include <sstream>

namespace twocam::landmarks {
namespace {

struct PolicyName {
  Policy policy;
  const char* name;
};
constexpr PolicyName kPolicyNames[] = {{Policy::kConsistency, "consistency"},
                                       {Policy::kWtaLrc, "wta-lrc"},
                                       {Policy::kSeenCount, "seen-count"},
                                       {Policy::kCulling, "culling"},
                                       {Policy::kInlierRatio, "inlier-ratio"}};

template <typename T>
Status bad(const char* key, T value, const char* constraint) {
  std::ostringstream msg;
  msg << "landmarks." << key << " = " << value << "; must be " << constraint;
  return Status::error(msg.str());
}

}  // namespace

const char* policyName(Policy policy) {
  for (const PolicyName& p : kPolicyNames) {
    if (p.policy == policy) return p.name;
  }
  return "unknown";
}

Status parsePolicy(const std::string& name, Policy* policy) {
  for (const PolicyName& p : kPolicyNames) {
    if (name == p.name) {
      *policy = p.policy;
      return Status::ok();
    }
  }
  return Status::error(
      "unknown policy '" + name +
      "'; expected one of: consistency, wta-lrc, seen-count, culling, inlier-ratio");
}

const std::vector<Policy>& allPolicies() {
  static const std::vector<Policy> policies = {Policy::kConsistency,
                                               Policy::kWtaLrc,
                                               Policy::kSeenCount,
                                               Policy::kCulling,
                                               Policy::kInlierRatio};
  return policies;
}

Status LandmarkOptions::validate() const {
  const auto finite_nonneg = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (!finite_nonneg(odom_trans_sigma_per_sqrt_m))
    return bad("odom_trans_sigma_per_sqrt_m", odom_trans_sigma_per_sqrt_m, ">= 0");
  if (!finite_nonneg(odom_trans_scale_sigma))
    return bad("odom_trans_scale_sigma", odom_trans_scale_sigma, ">= 0");
  if (!finite_nonneg(odom_rot_sigma_per_sqrt_rad))
    return bad("odom_rot_sigma_per_sqrt_rad", odom_rot_sigma_per_sqrt_rad, ">= 0");
  if (!finite_nonneg(odom_rot_scale_sigma))
    return bad("odom_rot_scale_sigma", odom_rot_scale_sigma, ">= 0");
  if (!finite_nonneg(odom_rot_sigma_per_m))
    return bad("odom_rot_sigma_per_m", odom_rot_sigma_per_m, ">= 0");
  if (!(pixel_sigma_px > 0.0 && std::isfinite(pixel_sigma_px)))
    return bad("pixel_sigma_px", pixel_sigma_px, "> 0");
  if (!(disparity_sigma_px > 0.0 && std::isfinite(disparity_sigma_px)))
    return bad("disparity_sigma_px", disparity_sigma_px, "> 0");
  if (!(gate_chi2 > 0.0 && std::isfinite(gate_chi2))) return bad("gate_chi2", gate_chi2, "> 0");
  if (!finite_nonneg(visibility_border_px))
    return bad("visibility_border_px", visibility_border_px, ">= 0");
  if (!(min_depth_m > 0.0 && std::isfinite(min_depth_m)))
    return bad("min_depth_m", min_depth_m, "> 0");
  if (!(min_disparity_px >= 0.0 && max_disparity_px > min_disparity_px &&
        std::isfinite(max_disparity_px))) {
    return bad("max_disparity_px", max_disparity_px, "> min_disparity_px >= 0");
  }
  if (!(prior_real > 0.0 && prior_real < 1.0)) return bad("prior_real", prior_real, "in (0, 1)");
  if (!(prior_real_lone > 0.0 && prior_real_lone < 1.0)) {
    return bad("prior_real_lone", prior_real_lone, "in (0, 1)");
  }
  if (!(detection_prob > 0.0 && detection_prob < 1.0))
    return bad("detection_prob", detection_prob, "in (0, 1)");
  if (!(max_hit_evidence > 0.0 && std::isfinite(max_hit_evidence)))
    return bad("max_hit_evidence", max_hit_evidence, "> 0");
  if (!finite_nonneg(stability_evidence))
    return bad("stability_evidence", stability_evidence, ">= 0");
  if (!finite_nonneg(evidence_step_m)) return bad("evidence_step_m", evidence_step_m, ">= 0");
  if (!(confirm_prob > 0.0 && confirm_prob < 1.0))
    return bad("confirm_prob", confirm_prob, "in (0, 1)");
  if (!(prune_prob >= 0.0 && prune_prob < confirm_prob))
    return bad("prune_prob", prune_prob, "in [0, confirm_prob)");
  if (!(anchor_gate_chi2 > 0.0)) return bad("anchor_gate_chi2", anchor_gate_chi2, "> 0");
  if (!(contradiction_evidence <= 0.0))
    return bad("contradiction_evidence", contradiction_evidence, "<= 0");
  if (!finite_nonneg(verify_min_offset_px))
    return bad("verify_min_offset_px", verify_min_offset_px, ">= 0");
  if (!finite_nonneg(verify_relative_offset))
    return bad("verify_relative_offset", verify_relative_offset, ">= 0");
  if (!finite_nonneg(verify_chi2)) return bad("verify_chi2", verify_chi2, ">= 0");
  if (!finite_nonneg(verify_llr)) return bad("verify_llr", verify_llr, ">= 0");
  if (!finite_nonneg(same_answer_px)) {
    return bad("same_answer_px", same_answer_px, ">= 0");
  }
  if (min_observations < 1) return bad("min_observations", min_observations, ">= 1");
  if (!(min_parallax_deg >= 0.0 && min_parallax_deg < 90.0)) {
    return bad("min_parallax_deg", min_parallax_deg, "in [0, 90)");
  }
  if (!(max_row_span_px >= 0.0)) return bad("max_row_span_px", max_row_span_px, ">= 0");
  if (!(max_row_span_relative >= 0.0))
    return bad("max_row_span_relative", max_row_span_relative, ">= 0");
  if (!(max_row_unsupported_fraction >= 0.0 && max_row_unsupported_fraction <= 1.0)) {
    return bad("max_row_unsupported_fraction", max_row_unsupported_fraction, "in [0, 1]");
  }
  if (seen_count_min < 1) return bad("seen_count_min", seen_count_min, ">= 1");
  if (!(seen_count_window_s > 0.0)) return bad("seen_count_window_s", seen_count_window_s, "> 0");
  if (!(culling_min_found_ratio >= 0.0 && culling_min_found_ratio <= 1.0))
    return bad("culling_min_found_ratio", culling_min_found_ratio, "in [0, 1]");
  if (culling_min_observations < 1)
    return bad("culling_min_observations", culling_min_observations, ">= 1");
  if (culling_decision_frames < 1)
    return bad("culling_decision_frames", culling_decision_frames, ">= 1");
  if (!(svo_converged_sigma_fraction > 0.0 && svo_converged_sigma_fraction < 1.0))
    return bad("svo_converged_sigma_fraction", svo_converged_sigma_fraction, "in (0, 1)");
  if (!(svo_min_inlier_ratio > 0.0 && svo_min_inlier_ratio < 1.0))
    return bad("svo_min_inlier_ratio", svo_min_inlier_ratio, "in (0, 1)");
  if (!(svo_prune_inlier_ratio >= 0.0 && svo_prune_inlier_ratio < svo_min_inlier_ratio))
    return bad("svo_prune_inlier_ratio", svo_prune_inlier_ratio, "in [0, svo_min_inlier_ratio)");
  if (max_consecutive_misses < 0)
    return bad("max_consecutive_misses", max_consecutive_misses, ">= 0");
  if (max_confirmed_misses < 1) return bad("max_confirmed_misses", max_confirmed_misses, ">= 1");
  if (max_frames_out_of_view < 0)
    return bad("max_frames_out_of_view", max_frames_out_of_view, ">= 0");
  if (max_confirmed < 1) return bad("max_confirmed", max_confirmed, ">= 1");
  if (max_candidates < 1) return bad("max_candidates", max_candidates, ">= 1");
  if (max_observations < 2) return bad("max_observations", max_observations, ">= 2");
  if (!(refine_huber > 0.0)) return bad("refine_huber", refine_huber, "> 0");
  return Status::ok();
}

}  // namespace twocam::landmarks
