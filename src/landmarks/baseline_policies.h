#pragma once
/// The baseline confirmation policies of the landmark-confidence experiments, run on the same
/// frontend output and the same tracker (prediction, gating, association, life cycle) as the
/// consistency policy so that only the rule differs. Each follows its published rule:
///   WtaLrcPolicy       best SAD with a left-right check, accepted at once;
///   SeenCountPolicy    MRPT CLandmarksMap: seen at least min_observations times within window_s;
///   CullingPolicy      ORB-SLAM MapPointCulling: found/visible >= min_found_ratio with at least
///                      min_observations, decided decision_frames after creation;
///   InlierRatioPolicy  SVO depth seed: Gaussian inverse depth x Beta inlier ratio, confirmed
///                      when converged with a high inlier ratio.
/// Options: SeenCountOptions, CullingOptions, InlierRatioOptions (landmarks/options.h).

#include <vector>

#include "landmarks/confirmation_policy.h"

namespace twocam::landmarks {

/// The confidence a baseline candidate starts with, before its rule first runs: its share of a
/// prior of 0.5 among the corner's candidates (left-right consistent ones count double). 0.5 is
/// consistency.prior_real's default, which the baselines were measured with (it orders the
/// candidate cap in the frame of their creation and is wta-lrc's reported confidence).
constexpr double kBaselineSeedPrior = 0.5;

/// Shared by the baselines: the initial confidence.
class BaselinePolicy : public ConfirmationPolicy {
 public:
  void onAllocate(uint32_t /*slot*/) override {}
  void onSeed(uint32_t slot, Landmark* l, const SeedInfo& seed, const FrameContext& f) override;
};

class WtaLrcPolicy final : public BaselinePolicy {
 public:
  /// Only the cheapest hypothesis of a corner, and only when it passed the left-right check.
  [[nodiscard]] bool seeds(const DisparityHypothesis& h) const override {
    return h.rank == 0 && h.lr_consistent;
  }
  [[nodiscard]] bool confirmsAtSeed() const override { return true; }
  Decision decide(uint32_t /*slot*/, Landmark* /*l*/, const FrameContext& /*f*/) override {
    return Decision::kConfirm;  // accepted at once
  }
};

class SeenCountPolicy final : public BaselinePolicy {
 public:
  explicit SeenCountPolicy(const SeenCountOptions& options) : options_(options) {}
  /// confidence = min(1, n_obs / min_observations).
  Decision decide(uint32_t slot, Landmark* l, const FrameContext& f) override;

 private:
  SeenCountOptions options_;
};

class CullingPolicy final : public BaselinePolicy {
 public:
  explicit CullingPolicy(const CullingOptions& options) : options_(options) {}
  /// confidence = min(1, n_obs / n_visible).
  Decision decide(uint32_t slot, Landmark* l, const FrameContext& f) override;

 private:
  CullingOptions options_;
};

class InlierRatioPolicy final : public BaselinePolicy {
 public:
  InlierRatioPolicy(const StereoRig& rig, const LandmarkOptions& options);

  /// The SVO seed of a candidate: inverse depth along the anchor ray [1/m], its variance, the
  /// Beta parameters and the inverse-depth range.
  struct State {
    float mu = 0.0f;
    float sigma2 = 0.0f;
    float a = 10.0f;
    float b = 10.0f;
    float range = 0.0f;
  };
  [[nodiscard]] const State& state(uint32_t slot) const { return state_[slot]; }

  void onAllocate(uint32_t slot) override;
  void onMeasured(uint32_t slot, const Landmark& l, const Eigen::Vector3d& p_cl) override;
  /// confidence = a / (a + b).
  Decision decide(uint32_t slot, Landmark* l, const FrameContext& f) override;
  void onSeed(uint32_t slot, Landmark* l, const SeedInfo& seed, const FrameContext& f) override;

 private:
  StereoRig rig_;
  Eigen::Isometry3d T_b_cl_;
  double min_depth_m_;
  double disparity_sigma_px_;
  InlierRatioOptions options_;
  std::vector<State> state_;
};

}  // namespace twocam::landmarks
