#include "eval/pose_consistency.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

#include "landmarks/landmark_model.h"

namespace twocam::eval {
namespace {

constexpr int kGaussNewtonIterations = 10;

/// Residuals (predicted - observed) of point p_w in all observations; false when behind a camera.
bool residuals(const StereoRig& rig,
               const std::vector<PosedObservation>& obs,
               const Eigen::Vector3d& p_w,
               Eigen::VectorXd* r) {
  r->resize(static_cast<Eigen::Index>(3 * obs.size()));
  for (size_t i = 0; i < obs.size(); ++i) {
    Eigen::Vector3d uvd;
    if (!landmarks::projectStereo(rig, obs[i].T_w_cl_true.inverse() * p_w, &uvd)) return false;
    r->segment<3>(static_cast<Eigen::Index>(3 * i)) =
        uvd - Eigen::Vector3d(obs[i].u_px, obs[i].v_px, obs[i].d_px);
  }
  return true;
}

}  // namespace

double trueTriangulationRmsPx(const StereoRig& rig,
                              const std::vector<PosedObservation>& observations) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (observations.size() < 2) return nan;
  const PosedObservation& first = observations.front();
  const auto p_cl = triangulateRectified(rig, Eigen::Vector2d(first.u_px, first.v_px), first.d_px);
  if (!p_cl) return nan;
  Eigen::Vector3d p = first.T_w_cl_true * *p_cl;
  Eigen::VectorXd r, r_step;
  if (!residuals(rig, observations, p, &r)) return nan;
  for (int it = 0; it < kGaussNewtonIterations; ++it) {
    // Central differences: a few observations of one point, so cost does not matter.
    Eigen::MatrixXd J(r.size(), 3);
    bool ok = true;
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6 * std::max(1.0, p.norm());
      Eigen::Vector3d dp = Eigen::Vector3d::Zero();
      dp[k] = h;
      Eigen::VectorXd rp, rm;
      ok = ok && residuals(rig, observations, p + dp, &rp) &&
           residuals(rig, observations, p - dp, &rm);
      if (ok) J.col(k) = (rp - rm) / (2.0 * h);
    }
    if (!ok) break;
    const Eigen::Vector3d step = (J.transpose() * J).ldlt().solve(-J.transpose() * r);
    if (!step.allFinite()) break;
    if (!residuals(rig, observations, p + step, &r_step) || r_step.squaredNorm() >= r.squaredNorm())
      break;
    p += step;
    r = r_step;
  }
  return std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
}

void TruePoseConsistency::addFrame(const StereoHypotheses& hyps,
                                   const landmarks::FrameReport& report,
                                   const Eigen::Isometry3d& T_w_b_true) {
  for (uint64_t id : report.removed_ids) observations_.erase(id);
  const Eigen::Isometry3d T_w_cl = T_w_b_true * rig_.T_b_cl;
  uint64_t last_id = 0;
  for (size_t j = 0; j < report.hypothesis_landmark_id.size() && j < hyps.hypotheses.size(); ++j) {
    const uint64_t id = report.hypothesis_landmark_id[j];
    if (id == 0 || id == last_id) continue;  // a corner's rivals point at one landmark in a row
    last_id = id;
    std::vector<PosedObservation>& list = observations_[id];
    if (static_cast<int>(list.size()) >= max_observations_) continue;
    if (!list.empty() && list.back().T_w_cl_true.isApprox(T_w_cl)) continue;  // once per frame
    const DisparityHypothesis& h = hyps.hypotheses[j];
    const Corner& c = hyps.points[h.point_index].corner;
    list.push_back({T_w_cl, static_cast<double>(c.u_px), static_cast<double>(c.v_px), h.d_px});
  }
}

PoseConsistencyMetrics TruePoseConsistency::finish(const landmarks::LandmarkDatabase& db) const {
  return finish(db.landmarks());
}

PoseConsistencyMetrics TruePoseConsistency::finish(
    const std::vector<landmarks::Landmark>& slots) const {
  PoseConsistencyMetrics m;
  for (const landmarks::Landmark& l : slots) {
    if (l.state != landmarks::LandmarkState::kConfirmed) continue;
    const auto it = observations_.find(l.id);
    if (it == observations_.end()) continue;
    const double rms = trueTriangulationRmsPx(rig_, it->second);
    if (!std::isfinite(rms)) {
      if (it->second.size() >= 2) ++m.judged;  // fits no point in front of the true cameras
      continue;
    }
    ++m.judged;
    m.consistent += rms <= kConsistentRmsPx ? 1 : 0;
  }
  m.fraction = m.judged > 0 ? static_cast<double>(m.consistent) / static_cast<double>(m.judged)
                            : std::numeric_limits<double>::quiet_NaN();
  return m;
}

}  // namespace twocam::eval
