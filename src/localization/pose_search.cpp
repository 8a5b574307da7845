#include "localization/pose_search.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <optional>
#include <string>

#include "common/status.h"

namespace twocam::localization {
namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
/// Nearest camera distance a landmark is projected at [m].
constexpr double kMinDepthM = 0.1;
/// Shortest planar distance between the two landmarks of a voting pair [m]: below it the
/// heading their candidates give is dominated by the depth error.
constexpr double kMinPairBaselineM = 0.3;
/// Fixed part of the height and pair-length tolerances [m] (the landmark's own position error).
constexpr double kPositionSlackM = 0.03;
/// The step fit: fewest inliers [-], Gauss-Newton iterations [-], Huber scale and inlier
/// chi-square (3 dof, 99 %) of the pixel residuals [px, px^2], numeric Jacobian step.
constexpr int kMinStepMatches = 8;
constexpr int kStepIterations = 6;
constexpr double kHuberSigma = 2.0;
constexpr double kInlierChi2 = 11.34;
constexpr double kJacobianStep = 1e-6;
/// Most candidates of one reference landmark in the wide search [-], and most votes [-]. 1-D
/// SAD's 2500 corners give a few hundred candidates in a 12 degree window and up to 3 million
/// votes at office_loops' slips (a cap of 160 candidates lost one of them and doubled garden's
/// ATE); a denser source (the Max-Tree's sparse points) would cost seconds in votes.
constexpr size_t kMaxCandidatesPerReference = 1000;
constexpr size_t kMaxVotes = size_t{1} << 22;
/// Most heading steps of the local search on either side [-].
constexpr int kMaxLocalSteps = 40;
/// Most refinements of the wide search's winner by the step fit [-]; they stop when a pass
/// explains no more, the cap only bounds the time. Each pass moves part of the way: chance
/// matches inside the match windows pull the fit towards the pose it started from (garden,
/// seed 4: three took the slip's pose from 605 to 790 matches of 889; garden_loops' slip at
/// frame 360 needed more than three to clear accept_fraction).
constexpr int kRefinePasses = 10;
/// Half-size of the box round a projection whose salient points give the chance of a match,
/// in match windows [-].
constexpr double kChanceRingMatchWindows = 4.0;

/// Planar pose error (dx, dy, dyaw) as an isometry of the predicted body frame.
Eigen::Isometry3d planarIsometry(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0.0);
  return T;
}

struct Projected {
  double u, v, d, z;
};

bool project(const StereoRig& rig, const Eigen::Vector3d& p_c, Projected* out) {
  if (!(p_c.z() > kMinDepthM)) return false;
  const double inv_z = 1.0 / p_c.z();
  out->u = rig.cx_px + rig.fx_px * p_c.x() * inv_z;
  out->v = rig.cy_px + rig.fy_px * p_c.y() * inv_z;
  out->d = rig.fx_px * rig.baseline_m * inv_z;
  out->z = p_c.z();
  return true;
}

/// project() onto a pixel of the image.
bool projectInImage(const StereoRig& rig, const Eigen::Vector3d& p_c, Projected* out) {
  return project(rig, p_c, out) && out->u >= 0.0 && out->v >= 0.0 && out->u <= rig.width_px - 1.0 &&
         out->v <= rig.height_px - 1.0;
}

}  // namespace

Pose2 fitPlanar(const std::vector<Eigen::Vector2d>& q, const std::vector<Eigen::Vector2d>& p) {
  TWOCAM_CHECK(q.size() == p.size() && !q.empty());
  Eigen::Vector2d mq = Eigen::Vector2d::Zero();
  Eigen::Vector2d mp = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < q.size(); ++i) {
    mq += q[i];
    mp += p[i];
  }
  mq /= static_cast<double>(q.size());
  mp /= static_cast<double>(p.size());
  double s_dot = 0.0;
  double s_cross = 0.0;
  for (size_t i = 0; i < q.size(); ++i) {
    const Eigen::Vector2d a = q[i] - mq;
    const Eigen::Vector2d b = p[i] - mp;
    s_dot += a.dot(b);
    s_cross += a.x() * b.y() - a.y() * b.x();
  }
  const double yaw = (s_dot == 0.0 && s_cross == 0.0) ? 0.0 : std::atan2(s_cross, s_dot);
  const Eigen::Rotation2Dd R(yaw);
  const Eigen::Vector2d t = mp - R * mq;
  return {t.x(), t.y(), yaw};
}

void PoseSearch::buildGrid(const StereoRig& rig, const StereoHypotheses& hyps) {
  cols_ = (rig.width_px + kCellPx - 1) / kCellPx;
  rows_ = (rig.height_px + kCellPx - 1) / kCellPx;
  const auto cells = static_cast<size_t>(cols_) * static_cast<size_t>(rows_);
  cell_start_.assign(cells + 1, 0);
  const auto cell_of = [&](const SalientPoint& p) -> size_t {
    const int c = std::clamp(p.corner.u_px / kCellPx, 0, cols_ - 1);
    const int r = std::clamp(p.corner.v_px / kCellPx, 0, rows_ - 1);
    return static_cast<size_t>(r) * static_cast<size_t>(cols_) + static_cast<size_t>(c);
  };
  for (const SalientPoint& p : hyps.points) ++cell_start_[cell_of(p) + 1];
  std::partial_sum(cell_start_.begin(), cell_start_.end(), cell_start_.begin());
  cell_points_.resize(hyps.points.size());
  std::vector<uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (uint32_t i = 0; i < hyps.points.size(); ++i)
    cell_points_[fill[cell_of(hyps.points[i])]++] = i;
  claimed_.assign(hyps.points.size(), 0);
  stamp_ = 0;
}

template <typename Fn>
void PoseSearch::forEachPointInCells(double u0, double u1, double v0, double v1, Fn&& fn) const {
  const int c0 = std::max(0, static_cast<int>(std::floor(u0 / kCellPx)));
  const int c1 = std::min(cols_ - 1, static_cast<int>(std::floor(u1 / kCellPx)));
  const int r0 = std::max(0, static_cast<int>(std::floor(v0 / kCellPx)));
  const int r1 = std::min(rows_ - 1, static_cast<int>(std::floor(v1 / kCellPx)));
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) {
      const size_t cell =
          static_cast<size_t>(r) * static_cast<size_t>(cols_) + static_cast<size_t>(c);
      for (uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) fn(cell_points_[k]);
    }
  }
}

int PoseSearch::scoreMatches(const StereoRig& rig,
                             const Eigen::Isometry3d& T_w_b,
                             const std::vector<Eigen::Vector3d>& reference_w,
                             const StereoHypotheses& hyps,
                             const PoseSearchOptions& o,
                             int* in_view,
                             std::vector<std::pair<int, uint32_t>>* matches) {
  if (++stamp_ == 0) {  // wrapped: forget every claim
    std::fill(claimed_.begin(), claimed_.end(), 0);
    stamp_ = 1;
  }
  if (matches != nullptr) matches->clear();
  const Eigen::Isometry3d T_cl_w = (T_w_b * rig.T_b_cl).inverse();
  int count = 0;
  int visible = 0;
  for (size_t i = 0; i < reference_w.size(); ++i) {
    Projected pr{};
    if (!projectInImage(rig, T_cl_w * reference_w[i], &pr)) continue;
    ++visible;
    double best = o.match_px * o.match_px * 2.0 + 1.0;
    int64_t best_point = -1;
    forEachPointInCells(
        pr.u - o.match_px,
        pr.u + o.match_px,
        pr.v - o.match_px,
        pr.v + o.match_px,
        [&](uint32_t pi) {
          if (claimed_[pi] == stamp_) return;
          const SalientPoint& sp = hyps.points[pi];
          const double du = sp.corner.u_px - pr.u;
          const double dv = sp.corner.v_px - pr.v;
          if (std::abs(du) > o.match_px || std::abs(dv) > o.match_px) return;
          const double dist2 = du * du + dv * dv;
          if (dist2 >= best) return;
          for (uint32_t h = sp.first_hypothesis; h < sp.first_hypothesis + sp.num_hypotheses; ++h) {
            if (std::abs(hyps.hypotheses[h].d_px - pr.d) <= o.match_disparity_px) {
              best = dist2;
              best_point = pi;
              return;
            }
          }
        });
    if (best_point < 0) continue;
    claimed_[static_cast<size_t>(best_point)] = stamp_;
    ++count;
    if (matches != nullptr) matches->emplace_back(static_cast<int>(i), best_point);
  }
  if (in_view != nullptr) *in_view = visible;
  return count;
}

bool PoseSearch::fitStep(const StereoRig& rig,
                         const Eigen::Isometry3d& T_w_b_predicted,
                         const std::vector<Eigen::Vector3d>& reference_w,
                         const StereoHypotheses& hyps,
                         const Pose2& start,
                         PoseSearchResult* result) const {
  // Observations: each match's corner and the hypothesis nearest the predicted disparity.
  struct Obs {
    Eigen::Vector3d p_w;
    double u, v, d;
  };
  std::vector<Obs> obs;
  obs.reserve(matches_.size());
  const double fb = rig.fx_px * rig.baseline_m;
  const Eigen::Isometry3d T_cl_w0 = (T_w_b_predicted * toIsometry(start) * rig.T_b_cl).inverse();
  for (const auto& [ref, point] : matches_) {
    const Eigen::Vector3d& p_w = reference_w[static_cast<size_t>(ref)];
    const double z = (T_cl_w0 * p_w).z();
    if (!(z > kMinDepthM)) continue;
    const SalientPoint& sp = hyps.points[point];
    double d_best = -1.0;
    for (uint32_t h = sp.first_hypothesis; h < sp.first_hypothesis + sp.num_hypotheses; ++h) {
      const double d = hyps.hypotheses[h].d_px;
      if (d_best < 0.0 || std::abs(d - fb / z) < std::abs(d_best - fb / z)) d_best = d;
    }
    obs.push_back(
        {p_w, static_cast<double>(sp.corner.u_px), static_cast<double>(sp.corner.v_px), d_best});
  }
  if (static_cast<int>(obs.size()) < kMinStepMatches) return false;
  // Residuals in pixels (sigma 1 px for u, v and d, as the pose update's defaults), Huber
  // weights at kHuberSigma, numeric Jacobian in (dx, dy, dyaw).
  const auto camera = [&](const Eigen::Vector3d& x) {
    return (T_w_b_predicted * toIsometry(Pose2{x.x(), x.y(), x.z()}) * rig.T_b_cl).inverse();
  };
  const auto residual = [&](const Eigen::Isometry3d& T_cl_w, const Obs& o, Eigen::Vector3d* r) {
    Projected pr{};
    if (!project(rig, T_cl_w * o.p_w, &pr)) return false;
    *r = Eigen::Vector3d(pr.u - o.u, pr.v - o.v, pr.d - o.d);
    return true;
  };
  Eigen::Vector3d x(start.x_m, start.y_m, start.yaw_rad);
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  int inliers = 0;
  for (int iter = 0; iter <= kStepIterations; ++iter) {
    H.setZero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    inliers = 0;
    // The camera at x and at x stepped along each axis, shared by every observation.
    const Eigen::Isometry3d T_cl_w = camera(x);
    std::array<Eigen::Isometry3d, 3> T_cl_w_step;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d xe = x;
      xe[k] += kJacobianStep;
      T_cl_w_step[static_cast<size_t>(k)] = camera(xe);
    }
    for (const Obs& o : obs) {
      Eigen::Vector3d r = Eigen::Vector3d::Zero();
      if (!residual(T_cl_w, o, &r)) continue;
      const double n = r.norm();
      const bool inlier = n * n <= kInlierChi2;
      const double w = n <= kHuberSigma ? 1.0 : kHuberSigma / n;
      Eigen::Matrix3d J;
      bool ok = true;
      for (int k = 0; k < 3 && ok; ++k) {
        Eigen::Vector3d re = Eigen::Vector3d::Zero();
        ok = residual(T_cl_w_step[static_cast<size_t>(k)], o, &re);
        J.col(k) = (re - r) / kJacobianStep;
      }
      if (!ok) continue;
      if (iter == kStepIterations) {
        if (inlier) {
          H += J.transpose() * J;
          ++inliers;
        }
        continue;
      }
      H += w * J.transpose() * J;
      g += w * J.transpose() * r;
    }
    if (iter == kStepIterations) break;
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(H);
    if (ldlt.info() != Eigen::Success) return false;
    x -= ldlt.solve(g);
  }
  if (inliers < kMinStepMatches) return false;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(H);
  if (!lu.isInvertible()) return false;
  result->step_measured = true;
  result->step = Pose2{x.x(), x.y(), x.z()};
  result->step_cov = lu.inverse();
  result->step_matches = inliers;
  return true;
}

double PoseSearch::chanceMatches(const StereoRig& rig,
                                 const Eigen::Isometry3d& T_w_b,
                                 const std::vector<Eigen::Vector3d>& reference_w,
                                 const StereoHypotheses& hyps,
                                 const PoseSearchOptions& o) const {
  const Eigen::Isometry3d T_cl_w = (T_w_b * rig.T_b_cl).inverse();
  const double ring_px = kChanceRingMatchWindows * o.match_px;
  double expected = 0.0;
  int visible = 0;
  int sampled = 0;
  const size_t stride =
      std::max<size_t>(1, reference_w.size() / static_cast<size_t>(std::max(1, o.max_reference)));
  for (size_t i = 0; i < reference_w.size(); ++i) {
    Projected pr{};
    if (!projectInImage(rig, T_cl_w * reference_w[i], &pr)) continue;
    ++visible;
    if (i % stride != 0) continue;
    ++sampled;
    // The ring: the box of half-size ring_px round the projection, clipped to the image,
    // without the match window itself.
    const double u0 = std::max(0.0, pr.u - ring_px),
                 u1 = std::min(rig.width_px - 1.0, pr.u + ring_px);
    const double v0 = std::max(0.0, pr.v - ring_px),
                 v1 = std::min(rig.height_px - 1.0, pr.v + ring_px);
    const double mu0 = std::max(u0, pr.u - o.match_px), mu1 = std::min(u1, pr.u + o.match_px);
    const double mv0 = std::max(v0, pr.v - o.match_px), mv1 = std::min(v1, pr.v + o.match_px);
    const double window_area = (mu1 - mu0 + 1.0) * (mv1 - mv0 + 1.0);
    const double ring_area = (u1 - u0 + 1.0) * (v1 - v0 + 1.0) - window_area;
    if (ring_area <= 0.0) continue;
    int in_ring = 0;
    forEachPointInCells(u0, u1, v0, v1, [&](uint32_t pi) {
      const SalientPoint& sp = hyps.points[pi];
      const double u = sp.corner.u_px, v = sp.corner.v_px;
      if (u < u0 || u > u1 || v < v0 || v > v1) return;
      if (u >= mu0 && u <= mu1 && v >= mv0 && v <= mv1) return;
      for (uint32_t h = sp.first_hypothesis; h < sp.first_hypothesis + sp.num_hypotheses; ++h) {
        if (std::abs(hyps.hypotheses[h].d_px - pr.d) <= o.match_disparity_px) {
          ++in_ring;
          return;
        }
      }
    });
    expected += 1.0 - std::exp(-in_ring * window_area / ring_area);
  }
  return sampled > 0 ? expected * visible / sampled : 0.0;
}

PoseSearchResult PoseSearch::run(const StereoRig& rig,
                                 const Eigen::Isometry3d& T_w_b_predicted,
                                 const Eigen::Matrix3d& prediction_cov,
                                 const std::vector<Eigen::Vector3d>& reference_w,
                                 const StereoHypotheses& hyps,
                                 const PoseSearchOptions& o,
                                 WideSearch wide) {
  PoseSearchResult result;
  result.T_w_b = T_w_b_predicted;
  buildGrid(rig, hyps);
  result.prediction_score =
      scoreMatches(rig, T_w_b_predicted, reference_w, hyps, o, &result.reference, &matches_);
  if (result.reference < o.min_reference) return result;
  // The scores count beyond chance: on dense texture (a lawn) a salient point with the right
  // disparity lies in many a match window whatever the pose (garden: ~45 % of the references
  // at any pose near the right one, 0.79 at the right one), so the shares below are of the
  // references in view that chance does not explain. Against the earlier map too: raw counts
  // re-anchored garden (held out, seeds 8 and 9) on the lawn's chance matches, 23 cm off.
  result.chance_score = chanceMatches(rig, T_w_b_predicted, reference_w, hyps, o);
  const double chance = result.chance_score;
  // The references chance does not explain; fewer than min_reference of them (texture so dense
  // that any pose matches nearly all) cannot tell poses apart: the check passes, as with too
  // few references in view.
  const double room = result.reference - chance;
  if (result.prediction_score - chance >= o.trigger_fraction * room || room < o.min_reference) {
    fitStep(rig, T_w_b_predicted, reference_w, hyps, Pose2{}, &result);
    return result;
  }
  // Within the prediction's own error: headings up to local_sigmas x its yaw sigma. In a turn
  // the odometry step's heading error alone is ~0.4 degree (3 px) per frame: no slip, and no
  // wide search needed. Steps of match_px (the scoring window covers the gap); with the
  // heading sweep (WideSearch::kAfterHeadingSweep), its steps of 2 x match_px over the whole
  // box, the local range being the part of it within the prediction's error.
  int local_score = result.prediction_score;
  double local_yaw = 0.0;
  int sweep_score = 0;
  const bool heading_sweep = wide == WideSearch::kAfterHeadingSweep;
  const double yaw_step = (heading_sweep ? 2.0 : 1.0) * o.match_px / rig.fx_px;
  const double yaw_range = o.local_sigmas * std::sqrt(std::max(0.0, prediction_cov(2, 2)));
  const int steps = heading_sweep
                        ? static_cast<int>(o.max_slip_deg * kDegToRad / yaw_step)
                        : std::min(kMaxLocalSteps, static_cast<int>(yaw_range / yaw_step));
  for (int k = -steps; k <= steps; ++k) {
    if (k == 0) continue;
    const double yaw = k * yaw_step;
    const int s = scoreMatches(rig,
                               T_w_b_predicted * toIsometry(Pose2{0.0, 0.0, yaw}),
                               reference_w,
                               hyps,
                               o,
                               nullptr,
                               nullptr);
    sweep_score = std::max(sweep_score, s);
    if (std::abs(yaw) > yaw_range + 1e-12) continue;
    if (s > local_score || (s == local_score && std::abs(yaw) < std::abs(local_yaw))) {
      local_score = s;
      local_yaw = yaw;
    }
  }
  if (local_score - chance >= o.trigger_fraction * room) {
    scoreMatches(rig,
                 T_w_b_predicted * toIsometry(Pose2{0.0, 0.0, local_yaw}),
                 reference_w,
                 hyps,
                 o,
                 nullptr,
                 &matches_);
    // Only measured: the prediction stays (a pose fitted to these observations as the prior
    // of an update on the same observations would count them twice; on office_loops applying
    // it let the estimate follow the frame-to-frame fit and drift, ATE 0.12 against 0.019 m).
    fitStep(rig, T_w_b_predicted, reference_w, hyps, Pose2{0.0, 0.0, local_yaw}, &result);
    result.heading_passed = true;
    // Against the earlier map that ends the check. Against the recent reference the heading
    // only raises the bar: a heading that lines up the far points passes with a fraction of
    // the references while the near ones need the position too (garden, seed 4, a 6 cm and
    // 2.5 degree slip: the heading 364 of 889, the slipped pose 790), so the wide search runs
    // and its pose must explain win_ratio x the heading's matches.
    if (heading_sweep) return result;
  }
  // A winner must explain win_ratio x the best heading's matches and can explain at most the
  // references in view: a search that could not be accepted is not run (most turns, where a
  // heading explains most of the references).
  if (o.win_ratio * (local_score - chance) > room) return result;
  if (heading_sweep && (sweep_score - chance < o.min_matches ||
                        sweep_score - chance < o.win_ratio * std::max(1.0, local_score - chance) ||
                        sweep_score - chance < o.trigger_fraction * room)) {
    return result;
  }
  result.searched = true;

  // Reference landmarks in the predicted body frame, in view of some pose of the search box,
  // an even stride of at most max_reference of them.
  const Eigen::Isometry3d T_b_w = T_w_b_predicted.inverse();
  const Eigen::Isometry3d T_cl_b = rig.T_b_cl.inverse();
  const double max_yaw = o.max_slip_deg * kDegToRad;
  const double fb = rig.fx_px * rig.baseline_m;
  std::vector<Eigen::Isometry3d> sweep;  // Delta^-1 over the corners and centre of the box
  for (int a = -1; a <= 1; ++a) {
    for (int b = -1; b <= 1; ++b) {
      for (int c = -1; c <= 1; ++c) {
        sweep.push_back(planarIsometry(a * o.max_slip_m, b * o.max_slip_m, c * max_yaw).inverse());
      }
    }
  }
  struct Ref {
    Eigen::Vector3d p_b;
    double z_m;
  };
  std::vector<Ref> refs;
  std::vector<size_t> all;
  for (size_t i = 0; i < reference_w.size(); ++i) all.push_back(i);
  const size_t stride = std::max<size_t>(1,
                                         (all.size() + static_cast<size_t>(o.max_reference) - 1) /
                                             static_cast<size_t>(o.max_reference));
  candidates_.clear();
  candidate_start_.clear();
  for (size_t k = 0; k < all.size(); k += stride) {
    const Eigen::Vector3d p_b = T_b_w * reference_w[all[k]];
    double u0 = 1e18, u1 = -1e18, v0 = 1e18, v1 = -1e18, d0 = 1e18, d1 = -1e18, z = 0.0;
    int n = 0;
    for (const Eigen::Isometry3d& S : sweep) {
      Projected pr{};
      if (!project(rig, T_cl_b * (S * p_b), &pr)) continue;
      u0 = std::min(u0, pr.u);
      u1 = std::max(u1, pr.u);
      v0 = std::min(v0, pr.v);
      v1 = std::max(v1, pr.v);
      d0 = std::min(d0, pr.d);
      d1 = std::max(d1, pr.d);
      z = std::max(z, pr.z);
      ++n;
    }
    if (n == 0) continue;
    u0 -= o.match_px;
    u1 += o.match_px;
    v0 -= o.match_px;
    v1 += o.match_px;
    d0 -= o.match_disparity_px;
    d1 += o.match_disparity_px;
    if (u1 < 0.0 || v1 < 0.0 || u0 > rig.width_px - 1.0 || v0 > rig.height_px - 1.0) continue;
    // Depth error of a disparity off by match_disparity_px at the landmark's farthest [m].
    const double depth_err = o.match_disparity_px * z * z / fb;
    const double height_tol = kPositionSlackM + depth_err * 0.5;
    const double range_tol = o.max_slip_m * std::sqrt(2.0) + depth_err + kPositionSlackM;
    const double range_ref = p_b.head<2>().norm();
    const auto begin = static_cast<uint32_t>(candidates_.size());
    forEachPointInCells(u0, u1, v0, v1, [&](uint32_t pi) {
      const SalientPoint& sp = hyps.points[pi];
      if (sp.corner.u_px < u0 || sp.corner.u_px > u1 || sp.corner.v_px < v0 || sp.corner.v_px > v1)
        return;
      for (uint32_t h = sp.first_hypothesis; h < sp.first_hypothesis + sp.num_hypotheses; ++h) {
        const double d = hyps.hypotheses[h].d_px;
        if (d < d0 || d > d1 || d <= 0.0) continue;
        const std::optional<Eigen::Vector3d> p_cl =
            triangulateRectified(rig, Eigen::Vector2d(sp.corner.u_px, sp.corner.v_px), d);
        if (!p_cl) continue;
        const Eigen::Vector3d q_b = rig.T_b_cl * *p_cl;
        if (std::abs(q_b.z() - p_b.z()) > height_tol) continue;
        if (std::abs(q_b.head<2>().norm() - range_ref) > range_tol) continue;
        candidates_.push_back({q_b, pi});
      }
    });
    // No candidate, or so many that the landmark's votes would be noise (a dense cluster of
    // points: it costs its square in votes and adds no information).
    if (candidates_.size() == begin || candidates_.size() - begin > kMaxCandidatesPerReference) {
      candidates_.resize(begin);
      continue;
    }
    refs.push_back({p_b, z});
    candidate_start_.push_back(begin);
  }
  candidate_start_.push_back(static_cast<uint32_t>(candidates_.size()));
  const size_t n_refs = refs.size();
  if (static_cast<int>(n_refs) < o.min_matches) return result;

  // Votes of rigid pairs: landmark i with i + n/2 and i + n/3 (in the order of the reference
  // list, which follows the database's), every candidate combination.
  // A vote lies inside the box, so a dense histogram over it counts them (kMaxVoteBins bins at
  // most, PoseSearchOptions::validate) instead of sorting up to kMaxVotes of them.
  const double bin_yaw = o.vote_deg * kDegToRad;
  const int64_t nbin_t = o.votePositionHalfBins();
  const int64_t nbin_yaw = o.voteHeadingHalfBins();
  const int64_t span_t = 2 * nbin_t + 1;
  const double tan_max_yaw = std::tan(max_yaw);
  votes_.assign(static_cast<size_t>(span_t * span_t * (2 * nbin_yaw + 1)), 0);
  size_t n_votes = 0;
  const size_t offsets[2] = {std::max<size_t>(1, n_refs / 2), std::max<size_t>(1, n_refs / 3)};
  // Votes past kMaxVotes would not be counted: the loops end there.
  for (size_t i = 0; i < n_refs && n_votes < kMaxVotes; ++i) {
    for (size_t off : offsets) {
      const size_t j = (i + off) % n_refs;
      if (j == i) continue;
      const Eigen::Vector2d pi = refs[i].p_b.head<2>();
      const Eigen::Vector2d pj = refs[j].p_b.head<2>();
      const Eigen::Vector2d dp = pi - pj;
      const double len_p = dp.norm();
      if (len_p < kMinPairBaselineM) continue;
      const double len_tol =
          kPositionSlackM * 2.0 +
          o.match_disparity_px * (refs[i].z_m * refs[i].z_m + refs[j].z_m * refs[j].z_m) / fb;
      for (uint32_t a = candidate_start_[i]; a < candidate_start_[i + 1] && n_votes < kMaxVotes;
           ++a) {
        for (uint32_t b = candidate_start_[j]; b < candidate_start_[j + 1] && n_votes < kMaxVotes;
             ++b) {
          if (candidates_[a].point == candidates_[b].point) continue;
          const Eigen::Vector2d qi = candidates_[a].q_b.head<2>();
          const Eigen::Vector2d qj = candidates_[b].q_b.head<2>();
          const Eigen::Vector2d dq = qi - qj;
          const double len_q = dq.norm();
          if (!(len_q > 0.0) || std::abs(len_q - len_p) > len_tol) continue;
          const double cross = dq.x() * dp.y() - dq.y() * dp.x();
          const double dot = dq.x() * dp.x() + dq.y() * dp.y();
          // |heading| <= max_yaw (under 90 degrees: validate) without the arctangent, which
          // only the votes kept need.
          if (!(dot > 0.0) || std::abs(cross) > tan_max_yaw * dot) continue;
          // The rotation from the pair's directions (its cosine and sine without sincos).
          Eigen::Matrix2d R;
          const double inv = 1.0 / (len_q * len_p);
          R << dot * inv, -cross * inv, cross * inv, dot * inv;
          const Eigen::Vector2d t = 0.5 * ((pi - R * qi) + (pj - R * qj));
          if (std::abs(t.x()) > o.max_slip_m || std::abs(t.y()) > o.max_slip_m) continue;
          const double yaw = std::atan2(cross, dot);
          const int64_t bx = std::llround(t.x() / o.vote_m) + nbin_t;
          const int64_t by = std::llround(t.y() / o.vote_m) + nbin_t;
          const int64_t byaw = std::llround(yaw / bin_yaw) + nbin_yaw;
          ++votes_[static_cast<size_t>((byaw * span_t + by) * span_t + bx)];
          ++n_votes;
        }
      }
    }
  }
  if (n_votes == 0) return result;
  std::vector<std::pair<int, int64_t>> bins;  // (-count, key): fullest first, then by key
  for (size_t k = 0; k < votes_.size(); ++k) {
    if (votes_[k] > 0) bins.emplace_back(-static_cast<int>(votes_[k]), static_cast<int64_t>(k));
  }
  size_t keep = std::min(bins.size(), static_cast<size_t>(o.scored_bins));
  std::partial_sort(bins.begin(), bins.begin() + static_cast<std::ptrdiff_t>(keep), bins.end());
  bins.resize(keep);
  if (o.point_bins > 0) {
    // Single-landmark votes (PoseSearchOptions::point_bins): at each heading bin, every
    // candidate of a reference landmark votes for the translation that puts the landmark on
    // it, a landmark at most once per bin.
    point_votes_.assign(votes_.size(), 0);
    point_voter_.assign(votes_.size(), 0);
    for (int64_t byaw = 0; byaw <= 2 * nbin_yaw; ++byaw) {
      const double yaw = static_cast<double>(byaw - nbin_yaw) * bin_yaw;
      if (std::abs(yaw) > max_yaw + 1e-12) continue;
      Eigen::Matrix2d R;
      R << std::cos(yaw), -std::sin(yaw), std::sin(yaw), std::cos(yaw);
      for (size_t i = 0; i < n_refs; ++i) {
        const Eigen::Vector2d pi = refs[i].p_b.head<2>();
        const auto voter = static_cast<uint32_t>(i + 1);
        for (uint32_t a = candidate_start_[i]; a < candidate_start_[i + 1]; ++a) {
          const Eigen::Vector2d t = pi - R * candidates_[a].q_b.head<2>();
          const int64_t bx = std::llround(t.x() / o.vote_m) + nbin_t;
          const int64_t by = std::llround(t.y() / o.vote_m) + nbin_t;
          if (bx < 0 || by < 0 || bx >= span_t || by >= span_t) continue;
          const auto k = static_cast<size_t>((byaw * span_t + by) * span_t + bx);
          if (point_voter_[k] == voter) continue;
          point_voter_[k] = voter;
          ++point_votes_[k];
        }
      }
    }
    std::vector<std::pair<int, int64_t>> pbins;
    for (size_t k = 0; k < point_votes_.size(); ++k) {
      if (point_votes_[k] > 0)
        pbins.emplace_back(-static_cast<int>(point_votes_[k]), static_cast<int64_t>(k));
    }
    const size_t pkeep = std::min(pbins.size(), static_cast<size_t>(o.point_bins) + keep);
    std::partial_sort(
        pbins.begin(), pbins.begin() + static_cast<std::ptrdiff_t>(pkeep), pbins.end());
    int added = 0;
    for (size_t k = 0; k < pkeep && added < o.point_bins; ++k) {
      bool seen = false;
      for (const auto& b : bins) seen = seen || b.second == pbins[k].second;
      if (seen) continue;
      bins.push_back(pbins[k]);
      ++added;
    }
    keep = bins.size();
  }

  // The search covers pose errors within the box (max_slip_m, max_slip_deg): candidates and
  // votes were taken there, and so were the rivals. A refit that leaves it chases chance
  // matches beyond what was searched (clutter at the disparities of the references' depths:
  // refits 28 degrees off, PoseSearch.ReferencesTurnedIntoViewAddChanceMatchesNotEvidence).
  const auto in_box = [&](const Pose2& c) {
    return std::abs(c.x_m) <= o.max_slip_m && std::abs(c.y_m) <= o.max_slip_m &&
           std::abs(c.yaw_rad) <= max_yaw;
  };
  int best_score = -1;
  Eigen::Isometry3d best_pose = T_w_b_predicted;
  Pose2 best_correction;
  std::vector<Eigen::Vector2d> q_fit;
  std::vector<Eigen::Vector2d> p_fit;
  std::vector<std::pair<int, Pose2>> tried;  // each bin's best score and pose
  // Each bin's matches at its best pose, back to back (tried_begin[k] .. tried_begin[k + 1]).
  tried_matches_.clear();
  std::vector<size_t> tried_begin;
  std::vector<std::pair<int, uint32_t>> bin_best;
  // The check's best heading, and the step fitted there when it passed, are scored first
  // like bins: evidence the votes may lack (the true pose's bin is not always among the
  // fullest; ring_hall's slip at frame 300 was found so).
  std::vector<Pose2> starts;
  if (!heading_sweep) {
    if (local_score > result.prediction_score) starts.push_back(Pose2{0.0, 0.0, local_yaw});
    if (result.heading_passed && result.step_measured && in_box(result.step))
      starts.push_back(result.step);
  }
  for (size_t k = 0; k < starts.size() + keep; ++k) {
    Pose2 correction;
    if (k < starts.size()) {
      correction = starts[k];
    } else {
      const int64_t key = bins[k - starts.size()].second;
      correction.x_m = (static_cast<double>(key % span_t) - static_cast<double>(nbin_t)) * o.vote_m;
      correction.y_m =
          (static_cast<double>((key / span_t) % span_t) - static_cast<double>(nbin_t)) * o.vote_m;
      correction.yaw_rad =
          (static_cast<double>(key / (span_t * span_t)) - static_cast<double>(nbin_yaw)) * bin_yaw;
    }
    tried.emplace_back(-1, correction);
    bin_best.clear();
    // Score the bin's pose, refit to its matches, score again (twice: the bin is coarse).
    for (int pass = 0; pass < 3; ++pass) {
      const Eigen::Isometry3d T = T_w_b_predicted * toIsometry(correction);
      const int s = scoreMatches(rig, T, reference_w, hyps, o, nullptr, &matches_);
      if (s > tried.back().first) {
        tried.back() = {s, correction};
        bin_best = matches_;
      }
      if (s > best_score) {
        best_score = s;
        best_pose = T;
        best_correction = correction;
      }
      if (pass == 2 || s < 3) break;
      q_fit.clear();
      p_fit.clear();
      for (const auto& [ref, point] : matches_) {
        const SalientPoint& sp = hyps.points[point];
        // The match's disparity: the hypothesis nearest the landmark's predicted one.
        const Eigen::Vector3d p_b = T_b_w * reference_w[static_cast<size_t>(ref)];
        const Eigen::Vector3d p_c_true = T_cl_b * (toIsometry(correction).inverse() * p_b);
        const double d_pred = fb / p_c_true.z();
        double d_best = -1.0;
        for (uint32_t h = sp.first_hypothesis; h < sp.first_hypothesis + sp.num_hypotheses; ++h) {
          const double d = hyps.hypotheses[h].d_px;
          if (d_best < 0.0 || std::abs(d - d_pred) < std::abs(d_best - d_pred)) d_best = d;
        }
        const std::optional<Eigen::Vector3d> p_cl =
            triangulateRectified(rig, Eigen::Vector2d(sp.corner.u_px, sp.corner.v_px), d_best);
        if (!p_cl) continue;
        q_fit.push_back((rig.T_b_cl * *p_cl).head<2>());
        p_fit.push_back(p_b.head<2>());
      }
      if (q_fit.size() < 3) break;
      const Pose2 refit = fitPlanar(q_fit, p_fit);
      if (!in_box(refit)) break;
      correction = refit;
    }
    tried_begin.push_back(tried_matches_.size());
    tried_matches_.insert(tried_matches_.end(), bin_best.begin(), bin_best.end());
  }
  tried_begin.push_back(tried_matches_.size());
  // The bins' refit is planar on triangulated points (coarse for far ones): refine the winner
  // by the step fit on pixels and disparity, rescored, while it explains more.
  // Against the earlier map (its references mostly hidden) the refinement would chase chance
  // matches: it re-anchored corridor_posters wrongly at frame 171 (ATE 0.026 -> 0.123 m).
  if (!heading_sweep) {
    for (int pass = 0; pass < kRefinePasses && best_score >= kMinStepMatches; ++pass) {
      scoreMatches(rig, best_pose, reference_w, hyps, o, nullptr, &matches_);
      PoseSearchResult refined;
      if (!fitStep(rig, T_w_b_predicted, reference_w, hyps, best_correction, &refined)) break;
      if (!in_box(refined.step)) break;
      const Eigen::Isometry3d T = T_w_b_predicted * toIsometry(refined.step);
      const int s = scoreMatches(rig, T, reference_w, hyps, o, nullptr, nullptr);
      if (s <= best_score) break;
      best_score = s;
      best_pose = T;
      best_correction = refined.step;
    }
  }
  // A periodic texture (or a scene seen twice) explains the references at another pose too:
  // the best of the poses two bins or more away from the winner must fall clearly short.
  // Against the recent reference a rival counts only the matches it does not share with the
  // winner (the same landmark on the same salient point): a pose shifted along the direction
  // the references constrain least (ground texture ahead) keeps most of the winner's matches,
  // and those are evidence for one answer, not for two. Against the earlier map (the heading
  // sweep's references, most of them hidden) a rival counts all its matches: what it shares
  // with the winner may be chance matches of both.
  const bool count_unshared = !heading_sweep;
  int best_in_view = result.reference;
  if (heading_sweep) {
    scoreMatches(rig, best_pose, reference_w, hyps, o, &best_in_view, nullptr);
  } else {
    winner_point_.assign(reference_w.size(), kNoPoint);
    scoreMatches(rig,
                 T_w_b_predicted * toIsometry(best_correction),
                 reference_w,
                 hyps,
                 o,
                 &best_in_view,
                 &matches_);
    for (const auto& [ref, point] : matches_) winner_point_[static_cast<size_t>(ref)] = point;
  }
  int rival_score = 0;
  for (size_t k = 0; k < tried.size(); ++k) {
    const Pose2& pose = tried[k].second;
    const bool distinct = std::hypot(pose.x_m - best_correction.x_m,
                                     pose.y_m - best_correction.y_m) > 2.0 * o.vote_m ||
                          std::abs(pose.yaw_rad - best_correction.yaw_rad) > 2.0 * bin_yaw;
    if (!distinct) continue;
    int score = tried[k].first;
    if (count_unshared) {
      for (size_t m = tried_begin[k]; m < tried_begin[k + 1]; ++m) {
        const auto& [ref, point] = tried_matches_[m];
        if (winner_point_[static_cast<size_t>(ref)] == point) --score;
      }
    }
    rival_score = std::max(rival_score, score);
  }
  result.rival_score = rival_score;
  result.best_score = std::max(0, best_score);
  result.best_correction = best_correction;
  // The winner is judged over the references in view of it, with the chance matches of as
  // many references at the prediction's rate: a pose turned towards more references draws
  // more chance matches (office held out, seed 9, frame 74: a pose 12 degrees off accepted with
  // 25 matches against 4.4 expected at the prediction, 18 of its 44 references in view there).
  // The rate is the prediction's, not chanceMatches at the winner: at the right pose the ring
  // round each projection holds the corners of the reference's neighbours, real structure
  // that would count as chance (office_loops seed 2, frame 781: 9.5 against 4.0 for as many
  // references, and its 8 degree slip refused).
  const double best_chance = result.reference > 0 ? chance * best_in_view / result.reference : 0.0;
  result.best_reference = best_in_view;
  result.best_chance_score = best_chance;
  const double best_excess = best_score - best_chance;
  const double best_room = best_in_view - best_chance;
  if (best_excess >= o.min_matches && winnerStandsOut(best_score, rival_score, o) &&
      best_excess >= o.win_ratio * std::max(1.0, local_score - chance) &&
      best_excess >= o.accept_fraction * best_room) {
    result.accepted = true;
    result.score = best_score;
    result.correction = best_correction;
    result.T_w_b = best_pose;
    scoreMatches(rig, best_pose, reference_w, hyps, o, nullptr, &matches_);
    fitStep(rig, T_w_b_predicted, reference_w, hyps, best_correction, &result);
  }
  return result;
}

bool winnerStandsOut(int best, int rival, const PoseSearchOptions& options) {
  return rival < options.ambiguity_ratio * best &&
         best - rival >= options.ambiguity_sigmas * std::sqrt(static_cast<double>(best + rival));
}

Eigen::Isometry3d associationPose(const PoseSearchResult& result,
                                  const Eigen::Isometry3d& T_w_b_predicted,
                                  const PoseSearchOptions& options) {
  if (options.associate_at_step && !result.accepted && !result.searched && result.heading_passed &&
      result.step_measured) {
    return T_w_b_predicted * toIsometry(result.step);
  }
  return result.T_w_b;
}

}  // namespace twocam::localization
