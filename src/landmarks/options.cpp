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
Status bad(const char* group, const char* key, T value, const char* constraint) {
  std::ostringstream msg;
  msg << "landmarks." << group << key << " = " << value << "; must be " << constraint;
  return Status::error(msg.str());
}

/// Checks of one group: `in(key, value, lo, hi)` closed, `open` variants exclusive; a NaN fails
/// every check. Collects the first failure.
class Check {
 public:
  explicit Check(const char* group) : group_(group) {}
  Check& closed(const char* key, double v, double lo, double hi, const char* text) {
    if (status_ && !(v >= lo && v <= hi)) status_ = bad(group_, key, v, text);
    return *this;
  }
  Check& lowOpen(const char* key, double v, double lo, double hi, const char* text) {
    if (status_ && !(v > lo && v <= hi)) status_ = bad(group_, key, v, text);
    return *this;
  }
  Check& open(const char* key, double v, double lo, double hi, const char* text) {
    if (status_ && !(v > lo && v < hi)) status_ = bad(group_, key, v, text);
    return *this;
  }
  Check& integer(const char* key, int v, int lo, int hi, const char* text) {
    if (status_ && !(v >= lo && v <= hi)) status_ = bad(group_, key, v, text);
    return *this;
  }
  [[nodiscard]] Status status() const { return status_; }

 private:
  const char* group_;
  Status status_ = Status::ok();
};

/// Upper bound of frame counts [frames]: about 18 hours at 15 Hz, far inside int.
constexpr int kMaxFrames = 1'000'000;

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
  static const std::vector<Policy> kPolicies = {Policy::kConsistency,
                                                Policy::kWtaLrc,
                                                Policy::kSeenCount,
                                                Policy::kCulling,
                                                Policy::kInlierRatio};
  return kPolicies;
}

Status TrackerOptions::validate() const {
  if (Status s = odometry_noise.validate("landmarks.tracker.odometry_noise."); !s) return s;
  Check c("tracker.");
  c.lowOpen("pixel_sigma_px", pixel_sigma_px, 0.0, 100.0, "in (0, 100]")
      .lowOpen("disparity_sigma_px", disparity_sigma_px, 0.0, 100.0, "in (0, 100]")
      .lowOpen("gate_chi2", gate_chi2, 0.0, 1000.0, "in (0, 1000]")
      .closed("visibility_border_px", visibility_border_px, 0.0, 10000.0, "in [0, 10000]")
      .lowOpen("min_depth_m", min_depth_m, 0.0, 1000.0, "in (0, 1000]")
      .closed("min_disparity_px", min_disparity_px, 0.0, 10000.0, "in [0, 10000]")
      .closed("fuse_disparity_px", fuse_disparity_px, 0.0, 100.0, "in [0, 100]");
  if (Status s = c.status(); !s) return s;
  // Below Harris' 2 px minimum corner spacing (TrackerOptions::fuse_radius_px).
  if (!(fuse_radius_px >= 0.0 && fuse_radius_px < 2.0))
    return bad("tracker.", "fuse_radius_px", fuse_radius_px, "in [0, 2)");
  if (!(max_disparity_px > min_disparity_px && max_disparity_px <= 10000.0))
    return bad("tracker.", "max_disparity_px", max_disparity_px, "> min_disparity_px, <= 10000");
  // Caps: the tracker reserves and sorts arrays of this size (about 1.2 kB per landmark).
  c.integer("max_consecutive_misses", max_consecutive_misses, 0, kMaxFrames, "in [0, 1000000]")
      .integer("max_confirmed_misses", max_confirmed_misses, 1, kMaxFrames, "in [1, 1000000]")
      .integer("max_frames_out_of_view", max_frames_out_of_view, 0, kMaxFrames, "in [0, 1000000]")
      .integer("max_confirmed", max_confirmed, 1, 10'000'000, "in [1, 10000000]")
      .integer("max_candidates", max_candidates, 1, 10'000'000, "in [1, 10000000]")
      .integer("max_observations", max_observations, 2, 1000, "in [2, 1000]");
  return c.status();
}

Status RefinementOptions::validate() const {
  return Check("refine.").lowOpen("huber", huber, 0.0, 1000.0, "in (0, 1000]").status();
}

Status ConsistencyOptions::validate() const {
  Check c("consistency.");
  c.open("prior_real", prior_real, 0.0, 1.0, "in (0, 1)")
      .open("detection_prob", detection_prob, 0.0, 1.0, "in (0, 1)")
      .lowOpen("max_hit_evidence", max_hit_evidence, 0.0, 100.0, "in (0, 100]")
      .closed("stability_evidence", stability_evidence, 0.0, 100.0, "in [0, 100]")
      .closed("evidence_step_m", evidence_step_m, 0.0, 1000.0, "in [0, 1000]")
      .lowOpen("anchor_gate_chi2", anchor_gate_chi2, 0.0, 1000.0, "in (0, 1000]")
      .closed("contradiction_evidence", contradiction_evidence, -100.0, 0.0, "in [-100, 0]")
      .open("confirm_prob", confirm_prob, 0.0, 1.0, "in (0, 1)")
      .closed("verify_min_offset_px", verify_min_offset_px, 0.0, 10000.0, "in [0, 10000]")
      .closed("verify_relative_offset", verify_relative_offset, 0.0, 100.0, "in [0, 100]")
      .closed("verify_llr", verify_llr, 0.0, 1000.0, "in [0, 1000]")
      .closed("same_answer_px", same_answer_px, 0.0, 10000.0, "in [0, 10000]")
      .closed("verify_chi2", verify_chi2, 0.0, 1000.0, "in [0, 1000]")
      .integer("min_observations", min_observations, 1, kMaxFrames, "in [1, 1000000]");
  if (Status s = c.status(); !s) return s;
  if (!(min_parallax_deg >= 0.0 && min_parallax_deg < 90.0))
    return bad("consistency.", "min_parallax_deg", min_parallax_deg, "in [0, 90)");
  if (!(prune_prob >= 0.0 && prune_prob < confirm_prob))
    return bad("consistency.", "prune_prob", prune_prob, "in [0, confirm_prob)");
  c.closed("max_row_span_px", max_row_span_px, 0.0, 10000.0, "in [0, 10000]")
      .closed("max_row_span_relative", max_row_span_relative, 0.0, 100.0, "in [0, 100]")
      .closed("max_row_unsupported_fraction", max_row_unsupported_fraction, 0.0, 1.0, "in [0, 1]");
  return c.status();
}

Status SeenCountOptions::validate() const {
  return Check("seen_count.")
      .integer("min_observations", min_observations, 1, kMaxFrames, "in [1, 1000000]")
      .lowOpen("window_s", window_s, 0.0, 1e6, "in (0, 1000000]")
      .status();
}

Status CullingOptions::validate() const {
  return Check("culling.")
      .closed("min_found_ratio", min_found_ratio, 0.0, 1.0, "in [0, 1]")
      .integer("min_observations", min_observations, 1, kMaxFrames, "in [1, 1000000]")
      .integer("decision_frames", decision_frames, 1, kMaxFrames, "in [1, 1000000]")
      .status();
}

Status InlierRatioOptions::validate() const {
  Check c("inlier_ratio.");
  c.open("converged_sigma_fraction", converged_sigma_fraction, 0.0, 1.0, "in (0, 1)")
      .open("min_inlier_ratio", min_inlier_ratio, 0.0, 1.0, "in (0, 1)");
  if (Status s = c.status(); !s) return s;
  if (!(prune_inlier_ratio >= 0.0 && prune_inlier_ratio < min_inlier_ratio))
    return bad(
        "inlier_ratio.", "prune_inlier_ratio", prune_inlier_ratio, "in [0, min_inlier_ratio)");
  return Status::ok();
}

Status LandmarkOptions::validate() const {
  if (Status s = tracker.validate(); !s) return s;
  if (Status s = refine.validate(); !s) return s;
  if (Status s = consistency.validate(); !s) return s;
  if (Status s = seen_count.validate(); !s) return s;
  if (Status s = culling.validate(); !s) return s;
  return inlier_ratio.validate();
}

}  // namespace twocam::landmarks
