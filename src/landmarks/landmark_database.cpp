#include "landmarks/landmark_database.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "landmarks/landmark_model.h"
#include "landmarks/refine.h"

namespace twocam::landmarks {
namespace {

/// Width of the cells of the per-frame hypothesis index [px] (cells are one row tall): about
/// the typical gate's half-width, so a row of a gate spans two to four cells.
constexpr int kCellWidthPx = 16;

double wrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

}  // namespace

LandmarkDatabase::LandmarkDatabase(const StereoRig& rig, const LandmarkOptions& options)
    : rig_(rig), options_(options), T_b_cl_(rig.T_b_cl) {
  const Status rig_status = rig.validate();
  TWOCAM_CHECK(rig_status.isOk()) << rig_status.message();
  const Status options_status = options.validate();
  TWOCAM_CHECK(options_status.isOk()) << options_status.message();
  policy_ = makeConfirmationPolicy(rig, options);
}

Status LandmarkDatabase::update(int32_t frame,
                                int64_t t_ns,
                                const Pose2& odom_pose,
                                const StereoHypotheses& hyps,
                                FrameReport* report) {
  if (Status s = beginFrame(frame, t_ns, odom_pose, hyps, report); !s) return s;
  finishFrame();
  return Status::ok();
}

const Landmark* LandmarkDatabase::find(uint64_t id) const {
  const uint32_t slot = slot_of_id_.find(id);
  return slot == IdIndex::kNone ? nullptr : &slots_[slot];
}

Status LandmarkDatabase::beginFrame(int32_t frame,
                                    int64_t t_ns,
                                    const Pose2& odom_pose,
                                    const StereoHypotheses& hyps,
                                    FrameReport* report) {
  TWOCAM_CHECK(report != nullptr);
  frame_hyps_ = nullptr;
  frame_report_ = nullptr;
  if (!std::isfinite(odom_pose.x_m) || !std::isfinite(odom_pose.y_m) ||
      !std::isfinite(odom_pose.yaw_rad)) {
    std::ostringstream msg;
    msg << "frame " << frame << ": odometry pose is not finite (x=" << odom_pose.x_m
        << ", y=" << odom_pose.y_m << ", yaw=" << odom_pose.yaw_rad << ")";
    return Status::error(msg.str());
  }
  if (has_previous_ && frame <= frame_) {
    return Status::error("frame index " + std::to_string(frame) + " does not follow frame " +
                         std::to_string(frame_));
  }
  if (has_previous_ && t_ns < t_ns_) {
    return Status::error("frame " + std::to_string(frame) + ": time stamp goes backwards (" +
                         std::to_string(t_ns) + " ns after " + std::to_string(t_ns_) + " ns)");
  }
  for (size_t i = 0; i < hyps.points.size(); ++i) {
    const SalientPoint& p = hyps.points[i];
    if (static_cast<size_t>(p.first_hypothesis) + p.num_hypotheses > hyps.hypotheses.size() ||
        p.corner.u_px < 0 || p.corner.v_px < 0 || p.corner.u_px >= rig_.width_px ||
        p.corner.v_px >= rig_.height_px) {
      return Status::error("frame " + std::to_string(frame) + ": salient point " +
                           std::to_string(i) +
                           " is outside the image or references missing hypotheses");
    }
  }
  for (const DisparityHypothesis& h : hyps.hypotheses) {
    if (h.point_index >= hyps.points.size() || !std::isfinite(h.d_px)) {
      return Status::error("frame " + std::to_string(frame) +
                           ": a hypothesis has a bad point index or disparity");
    }
  }

  report->frame = frame;
  report->hypotheses = static_cast<int>(hyps.hypotheses.size());
  report->predicted_visible = report->associated = report->seeded = 0;
  report->confirmed = report->pruned = report->refined = 0;
  report->probed = report->probe_found = 0;
  report->reassociated = 0;
  report->fused = 0;
  report->reclaimed = 0;
  report->fused_ids.clear();
  report->created_ids.clear();
  report->associated_ids.clear();
  report->confirmed_ids.clear();
  report->created_hypotheses.clear();
  report->removed_ids.clear();
  report->hypothesis_landmark_id.assign(hyps.hypotheses.size(), 0);

  if (has_previous_) {
    path_m_ += std::hypot(odom_pose.x_m - pose_.x_m, odom_pose.y_m - pose_.y_m);
    turn_rad_ += std::abs(wrapAngle(odom_pose.yaw_rad - pose_.yaw_rad));
  }
  has_previous_ = true;
  frame_ = frame;
  t_ns_ = t_ns;
  pose_ = odom_pose;
  T_w_cl_ = cameraPoseInWorld(odom_pose, T_b_cl_);
  {
    PoseRingEntry& e = pose_ring_[static_cast<uint32_t>(frame) % kPoseRingSize];
    e.frame = frame;
    e.T_w_cl = T_w_cl_;
  }
  T_cl_w_ = T_w_cl_.inverse();
  frame_ctx_.frame = frame;
  frame_ctx_.t_ns = t_ns;
  frame_ctx_.odom_pose = odom_pose;
  frame_ctx_.T_w_cl = T_w_cl_;
  frame_ctx_.T_cl_w = T_cl_w_;
  frame_ctx_.path_m = path_m_;
  frame_ctx_.turn_rad = turn_rad_;

  // Per-frame hypothesis index: the hypotheses counting-sorted (O(N)) into cells one image row
  // tall and kCellWidthPx wide, row-major, so that the cells a gate spans in one row form one
  // contiguous range: a prediction reads two offsets per row and scans only the hypotheses in
  // its gate's rows and columns (rounded out to whole cells). No all-pairs scan.
  const int cells_per_row = (rig_.width_px + kCellWidthPx - 1) / kCellWidthPx;
  const int num_cells = cells_per_row * rig_.height_px;
  const size_t num_hyps = hyps.hypotheses.size();
  cell_start_.assign(static_cast<size_t>(num_cells) + 1, 0);
  for (const DisparityHypothesis& h : hyps.hypotheses) {
    const Corner& c = hyps.points[h.point_index].corner;
    ++cell_start_[c.v_px * cells_per_row + c.u_px / kCellWidthPx + 1];
  }
  for (int i = 0; i < num_cells; ++i) cell_start_[i + 1] += cell_start_[i];
  grid_items_.resize(num_hyps);
  grid_uvd_.resize(num_hyps);
  {
    std::vector<int32_t>& fill = hyp_claim_;  // reused as a cursor array before the claims
    fill.assign(cell_start_.begin(), cell_start_.end() - 1);
    for (size_t j = 0; j < num_hyps; ++j) {
      const DisparityHypothesis& h = hyps.hypotheses[j];
      const Corner& c = hyps.points[h.point_index].corner;
      const int32_t k = fill[c.v_px * cells_per_row + c.u_px / kCellWidthPx]++;
      grid_items_[k] = static_cast<int32_t>(j);
      grid_uvd_[k] = {
          static_cast<float>(c.u_px), static_cast<float>(c.v_px), h.d_px, h.point_index};
    }
  }
  const double d_range =
      options_.tracker.max_disparity_px - options_.tracker.min_disparity_px + 1.0;
  corner_density_ = static_cast<double>(hyps.points.size()) /
                    (static_cast<double>(rig_.width_px) * rig_.height_px);
  hypothesis_density_ = static_cast<double>(hyps.hypotheses.size()) /
                        (static_cast<double>(rig_.width_px) * rig_.height_px * d_range);

  frame_obs_.clear();
  confirmed_obs_.clear();
  fusion_index_built_ = false;
  predictAll(T_cl_w_, hyps);
  associate(hyps, report);
  frame_hyps_ = &hyps;
  frame_report_ = report;
  probe_requests_built_ = false;
  probe_pixels_.clear();
  probe_prediction_.clear();
  return Status::ok();
}

LandmarkDatabase::Gate LandmarkDatabase::estimateGate(const Landmark& l,
                                                      const Eigen::Vector3d& uvd,
                                                      double z_m,
                                                      const OdometryErrorSigma& sigma) const {
  const OdometryErrorSigma odo = accumulatedOdometrySigma(options_.tracker.odometry_noise,
                                                          path_m_ - l.path_at_last_seen_m,
                                                          turn_rad_ - l.turn_at_last_seen_rad);
  const MeasurementSigma st = predictionSigmaFor(
      options_.tracker,
      rig_,
      uvd,
      z_m,
      OdometryErrorSigma{std::min(odo.trans_m, kMapPoseErrorFactor * sigma.trans_m),
                         std::min(odo.yaw_rad, kMapPoseErrorFactor * sigma.yaw_rad)});
  const double g = std::sqrt(options_.tracker.gate_chi2);
  return Gate{static_cast<float>(1.0 / (st.u_px * st.u_px)),
              static_cast<float>(1.0 / (st.v_px * st.v_px)),
              static_cast<float>(1.0 / (st.d_px * st.d_px)),
              static_cast<float>(g * st.u_px),
              static_cast<float>(g * st.v_px)};
}

template <typename Visit>
void LandmarkDatabase::scanGate(
    double u, double v, double gate_u, double gate_v, Visit&& visit) const {
  const int cells_per_row = (rig_.width_px + kCellWidthPx - 1) / kCellWidthPx;
  const int r0 = std::max(0, static_cast<int>(std::ceil(v - gate_v)));
  const int r1 = std::min(rig_.height_px - 1, static_cast<int>(std::floor(v + gate_v)));
  const int c0 = std::max(0, static_cast<int>((u - gate_u) / kCellWidthPx));
  const int c1 = std::min(cells_per_row - 1, static_cast<int>((u + gate_u) / kCellWidthPx));
  for (int r = r0; r <= r1 && c0 <= c1; ++r) {
    const GridEntry* row_end = grid_uvd_.data() + cell_start_[r * cells_per_row + c1 + 1];
    for (const GridEntry* it = grid_uvd_.data() + cell_start_[r * cells_per_row + c0];
         it != row_end;
         ++it) {
      if (!visit(*it, grid_items_[it - grid_uvd_.data()])) return;
    }
  }
}

Status LandmarkDatabase::correctFramePose(const Pose2& pose,
                                          const std::optional<OdometryErrorSigma>& sigma) {
  TWOCAM_CHECK(frame_hyps_ != nullptr) << "correctFramePose outside a frame";
  if (!std::isfinite(pose.x_m) || !std::isfinite(pose.y_m) || !std::isfinite(pose.yaw_rad)) {
    return Status::error("frame " + std::to_string(frame_) + ": corrected pose is not finite");
  }
  pose_ = pose;
  T_w_cl_ = cameraPoseInWorld(pose, T_b_cl_);
  T_cl_w_ = T_w_cl_.inverse();
  pose_ring_[static_cast<uint32_t>(frame_) % kPoseRingSize].T_w_cl = T_w_cl_;
  frame_ctx_.odom_pose = pose;
  frame_ctx_.T_w_cl = T_w_cl_;
  frame_ctx_.T_cl_w = T_cl_w_;
  for (const FrameObservation& o : frame_obs_) {
    Landmark& l = slots_[o.slot];
    if (!l.observations.empty() && l.observations.back().frame == frame_)
      l.observations.back().odom_pose = pose;
    if (map_frame_predictions_ && l.state == LandmarkState::kConfirmed) continue;
    if (const auto p_cl = triangulateRectified(rig_, Eigen::Vector2d(o.u_px, o.v_px), o.d_px)) {
      l.p_w_last = T_w_cl_ * *p_cl;
      hot_[o.slot].p_w_last = l.p_w_last;
    }
  }
  if (sigma) reassociateConfirmed(*sigma);
  return Status::ok();
}

void LandmarkDatabase::unassociatedConfirmedInView(int32_t seen_before,
                                                   size_t max_count,
                                                   std::vector<uint64_t>* ids) {
  TWOCAM_CHECK(frame_hyps_ != nullptr) << "unassociatedConfirmedInView outside a frame";
  ranked_.clear();
  for (const Prediction& p : predictions_) {
    if (!p.confirmed || associated_[p.slot]) continue;
    const Landmark& l = slots_[p.slot];
    if (l.state == LandmarkState::kConfirmed && l.last_seen_frame < seen_before)
      ranked_.emplace_back(-static_cast<int64_t>(l.n_obs), l.id);
  }
  const size_t keep = std::min(max_count, ranked_.size());
  std::partial_sort(
      ranked_.begin(), ranked_.begin() + static_cast<std::ptrdiff_t>(keep), ranked_.end());
  ids->clear();
  for (size_t i = 0; i < keep; ++i) ids->push_back(ranked_[i].second);
  std::sort(ids->begin(), ids->end());
}

void LandmarkDatabase::reassociateConfirmed(const OdometryErrorSigma& sigma) {
  const StereoHypotheses& hyps = *frame_hyps_;
  FrameReport* report = frame_report_;
  const float gate = static_cast<float>(options_.tracker.gate_chi2);
  const auto explained = [&](uint32_t point_index) {
    const SalientPoint& sp = hyps.points[point_index];
    for (uint32_t k = 0; k < sp.num_hypotheses; ++k) {
      if (report->hypothesis_landmark_id[sp.first_hypothesis + k] != 0) return true;
    }
    return false;
  };
  const size_t n_predictions = predictions_.size();
  for (size_t i = 0; i < n_predictions; ++i) {
    const Prediction& p = predictions_[i];
    if (!p.confirmed || associated_[p.slot] || contradicted_[p.slot]) continue;
    const Landmark& l = slots_[p.slot];
    const Eigen::Vector3d p_cl = T_cl_w_ * hot_[p.slot].p_w_last;
    Eigen::Vector3d uvd;
    if (p_cl.z() < options_.tracker.min_depth_m || !projectStereo(rig_, p_cl, &uvd)) continue;
    const Gate gt = estimateGate(l, uvd, p_cl.z(), sigma);
    int32_t best = -1;
    float best_d2 = gate;
    uint32_t first_point = UINT32_MAX;
    bool ambiguous = false;
    scanGate(uvd.x(), uvd.y(), gt.gate_u, gt.gate_v, [&](const GridEntry& e, int32_t j) {
      const double du = e.u - uvd.x(), dv = e.v - uvd.y(), dd = e.d - uvd.z();
      const auto d2 = static_cast<float>(du * du * gt.inv_var_u + dv * dv * gt.inv_var_v +
                                         dd * dd * gt.inv_var_d);
      if (d2 > gate) return true;
      if (first_point == UINT32_MAX) {
        first_point = e.point_index;
      } else if (e.point_index != first_point) {
        ambiguous = true;
        return false;
      }
      if (d2 < best_d2) {
        best = j;
        best_d2 = d2;
      }
      return true;
    });
    if (best < 0 || ambiguous || explained(first_point)) continue;
    const DisparityHypothesis& h = hyps.hypotheses[best];
    associated_[p.slot] = 1;
    if (!applyObservation(p.slot, h, hyps.points[h.point_index].corner)) continue;
    report->hypothesis_landmark_id[best] = l.id;
    report->associated_ids.push_back(l.id);
    ++report->associated;
    ++report->associated_confirmed;
    ++report->reassociated;
  }
}

void LandmarkDatabase::finishFrame() {
  TWOCAM_CHECK(frame_hyps_ != nullptr) << "finishFrame without a successful beginFrame";
  FrameReport* report = frame_report_;
  scoreAndLifeCycle(report);
  seed(*frame_hyps_, report);
  enforceCaps(report);
  frame_hyps_ = nullptr;
  frame_report_ = nullptr;
}

void LandmarkDatabase::predictAll(const Eigen::Isometry3d& T_cl_w,
                                  const StereoHypotheses& /*hyps*/) {
  predictions_.clear();
  tight_gates_.clear();
  has_tight_gates_ = prediction_sigma_.has_value();
  map_frame_predictions_ = has_tight_gates_;
  visible_.assign(slots_.size(), 0);
  associated_.assign(slots_.size(), 0);
  contradicted_.assign(slots_.size(), 0);
  probed_.assign(slots_.size(), 0);
  policy_->beginFrame(slots_.size());
  const double border = options_.tracker.visibility_border_px;
  const double g = std::sqrt(options_.tracker.gate_chi2);
  const double ellipsoid = 4.0 / 3.0 * M_PI * g * g * g;
  // The visibility test reads only the compact per-slot copies (hot_): most slots are confirmed
  // landmarks out of view, whose full records are then not touched.
  for (uint32_t s = 0; s < slots_.size(); ++s) {
    const HotSlot& hot = hot_[s];
    if (hot.state == LandmarkState::kFree) continue;
    const Eigen::Vector3d p_cl = T_cl_w * hot.p_w_last;
    Eigen::Vector3d uvd;
    const bool in_view = p_cl.z() >= options_.tracker.min_depth_m &&
                         projectStereo(rig_, p_cl, &uvd) && uvd.x() >= border &&
                         uvd.x() <= rig_.width_px - 1 - border && uvd.y() >= border &&
                         uvd.y() <= rig_.height_px - 1 - border &&
                         uvd.z() >= options_.tracker.min_disparity_px - 1.0 &&
                         uvd.z() <= options_.tracker.max_disparity_px + 1.0;
    if (!in_view) {
      // Only candidates age out of view; confirmed landmarks are kept until they return.
      if (hot.state == LandmarkState::kCandidate) ++slots_[s].frames_out_of_view;
      continue;
    }
    Landmark& l = slots_[s];
    l.frames_out_of_view = 0;
    l.last_visible_frame = frame_;
    ++l.n_visible;
    visible_[s] = 1;
    const MeasurementSigma sigma = predictionSigma(options_.tracker,
                                                   rig_,
                                                   uvd,
                                                   p_cl.z(),
                                                   path_m_ - l.path_at_last_seen_m,
                                                   turn_rad_ - l.turn_at_last_seen_rad);
    Prediction p;
    p.slot = s;
    p.confirmed = hot.state == LandmarkState::kConfirmed;
    p.u = static_cast<float>(uvd.x());
    p.v = static_cast<float>(uvd.y());
    p.d = static_cast<float>(uvd.z());
    p.inv_var_u = static_cast<float>(1.0 / (sigma.u_px * sigma.u_px));
    p.inv_var_v = static_cast<float>(1.0 / (sigma.v_px * sigma.v_px));
    p.inv_var_d = static_cast<float>(1.0 / (sigma.d_px * sigma.d_px));
    p.gate_u = static_cast<float>(g * sigma.u_px);
    p.gate_v = static_cast<float>(g * sigma.v_px);
    p.p_false_hit_per_hyp = static_cast<float>(
        std::min(0.99, hypothesis_density_ * ellipsoid * sigma.u_px * sigma.v_px * sigma.d_px));
    predictions_.push_back(p);
    if (has_tight_gates_) {
      Gate t{p.inv_var_u, p.inv_var_v, p.inv_var_d, p.gate_u, p.gate_v};
      if (p.confirmed) {
        t = estimateGate(l, uvd, p_cl.z(), *prediction_sigma_);
      }
      tight_gates_.push_back(t);
    }
  }
}

void LandmarkDatabase::associate(const StereoHypotheses& hyps, FrameReport* report) {
  const float gate = static_cast<float>(options_.tracker.gate_chi2);
  // Confirmed landmarks choose first: a corner they explain is not given to a candidate.
  // Candidates then compete by Mahalanobis distance; a displaced candidate counts as unseen.
  std::vector<int32_t> pred_hyp;
  const bool reject_ambiguous = policy_->rejectsAmbiguousConfirmedHits();
  // One association of every prediction; `tight`: confirmed landmarks with the estimate's gates
  // (setPredictionSigma). Returns the confirmed landmarks associated.
  const auto match = [&](bool tight) {
    hyp_claim_.assign(hyps.hypotheses.size(), -1);
    hyp_claim_d2_.assign(hyps.hypotheses.size(), 0.0f);
    pred_hyp.assign(predictions_.size(), -1);
    int confirmed_hits = 0;
    for (int pass = 0; pass < 2; ++pass) {
      const bool wanted = pass == 0;  // confirmed landmarks first
      for (size_t i = 0; i < predictions_.size(); ++i) {
        const Prediction& p = predictions_[i];
        if (p.confirmed != wanted) continue;
        const bool use_tight = tight && p.confirmed;
        const float inv_var_u = use_tight ? tight_gates_[i].inv_var_u : p.inv_var_u;
        const float inv_var_v = use_tight ? tight_gates_[i].inv_var_v : p.inv_var_v;
        const float inv_var_d = use_tight ? tight_gates_[i].inv_var_d : p.inv_var_d;
        const float gate_u = use_tight ? tight_gates_[i].gate_u : p.gate_u;
        const float gate_v = use_tight ? tight_gates_[i].gate_v : p.gate_v;
        int32_t best = -1;
        float best_d2 = gate;
        // Confirmed landmarks (consistency policy): distinct corners inside the gate. With more
        // than one the association is ambiguous and is not made (see below).
        const bool count_points = pass == 0 && reject_ambiguous;
        uint32_t first_point = UINT32_MAX;
        bool ambiguous = false;
        // An ambiguous gate is not associated whatever else it holds, so the scan stops at the
        // second corner (on office the drift-widened gates of confirmed landmarks held 30
        // hypotheses on average).
        scanGate(p.u, p.v, gate_u, gate_v, [&](const GridEntry& e, int32_t j) {
          const float du = e.u - p.u;
          const float dv = e.v - p.v;
          const float dd = e.d - p.d;
          const float d2 = du * du * inv_var_u + dv * dv * inv_var_v + dd * dd * inv_var_d;
          if (d2 > gate) return true;
          if (count_points) {
            if (first_point == UINT32_MAX) {
              first_point = e.point_index;
            } else if (e.point_index != first_point) {
              ambiguous = true;
              return false;
            }
          }
          if (d2 > best_d2) return true;
          const int32_t owner = hyp_claim_[j];
          if (owner >= 0) {
            // Held by a confirmed landmark (pass 0) or by a nearer candidate: not available.
            if (predictions_[owner].confirmed && pass == 1) return true;
            if (hyp_claim_d2_[j] <= d2) return true;
          }
          best = j;
          best_d2 = d2;
          return true;
        });
        // A confirmed landmark whose gate holds several corners cannot tell which one is its
        // own (after a long absence odometry drift has widened the gate): taking the nearest
        // would let it live on a neighbouring corner while its own is confirmed again as a
        // duplicate. It counts as unseen; if that lasts, it is retired and its corner
        // re-confirmed afresh.
        if (best < 0 || ambiguous) continue;
        const int32_t previous = hyp_claim_[best];
        if (previous >= 0) {
          confirmed_hits -= predictions_[previous].confirmed ? 1 : 0;
          pred_hyp[previous] = -1;
        }
        hyp_claim_[best] = static_cast<int32_t>(i);
        hyp_claim_d2_[best] = best_d2;
        pred_hyp[i] = best;
        confirmed_hits += p.confirmed ? 1 : 0;
      }
    }
    return confirmed_hits;
  };
  int confirmed_hits = match(has_tight_gates_);
  report->gates_widened = false;
  if (has_tight_gates_ && confirmed_hits < kWidenBelowFraction * previous_associated_confirmed_) {
    // Too few for the estimate's covariance: try the odometry gates, keep the better pass.
    std::vector<int32_t> tight_pred = pred_hyp, tight_claim = hyp_claim_;
    std::vector<float> tight_d2 = hyp_claim_d2_;
    const int wide_hits = match(false);
    if (wide_hits > confirmed_hits) {
      confirmed_hits = wide_hits;
      report->gates_widened = true;
    } else {
      pred_hyp.swap(tight_pred);
      hyp_claim_.swap(tight_claim);
      hyp_claim_d2_.swap(tight_d2);
    }
  }
  report->associated_confirmed = confirmed_hits;
  previous_associated_confirmed_ = confirmed_hits;
  for (size_t i = 0; i < predictions_.size(); ++i) {
    if (pred_hyp[i] < 0) continue;
    const uint32_t slot = predictions_[i].slot;
    const DisparityHypothesis& h = hyps.hypotheses[pred_hyp[i]];
    associated_[slot] = 1;
    if (!applyObservation(slot, h, hyps.points[h.point_index].corner)) continue;  // contradicted
    report->hypothesis_landmark_id[pred_hyp[i]] = slots_[slot].id;
    report->associated_ids.push_back(slots_[slot].id);
    ++report->associated;
  }
  report->predicted_visible = static_cast<int>(predictions_.size());
}

const std::vector<Corner>& LandmarkDatabase::probeRequests() {
  TWOCAM_CHECK(frame_hyps_ != nullptr) << "probeRequests outside a frame";
  if (probe_requests_built_) return probe_pixels_;
  probe_requests_built_ = true;
  probe_pixels_.clear();
  probe_prediction_.clear();
  if (!policy_->probesUnseen()) return probe_pixels_;
  for (uint32_t i = 0; i < predictions_.size(); ++i) {
    const Prediction& p = predictions_[i];
    if (p.confirmed || associated_[p.slot]) continue;
    Corner c;
    c.u_px = static_cast<int>(std::lround(p.u));
    c.v_px = static_cast<int>(std::lround(p.v));
    probe_pixels_.push_back(c);
    probe_prediction_.push_back(i);
  }
  frame_report_->probed = static_cast<int>(probe_pixels_.size());
  return probe_pixels_;
}

Status LandmarkDatabase::addProbeResults(const StereoHypotheses& measured) {
  TWOCAM_CHECK(frame_hyps_ != nullptr && probe_requests_built_)
      << "addProbeResults without probeRequests";
  // The probe returns one point per pixel whose window fit, in request order: walk both lists.
  // Checked first, so that an error marks nothing.
  {
    size_t k = 0;
    for (const SalientPoint& sp : measured.points) {
      while (k < probe_pixels_.size() &&
             (probe_pixels_[k].u_px != sp.corner.u_px || probe_pixels_[k].v_px != sp.corner.v_px)) {
        ++k;
      }
      if (k == probe_pixels_.size()) {
        return Status::error("frame " + std::to_string(frame_) +
                             ": re-measuring unseen candidates: the probe returned a pixel it was "
                             "not asked for");
      }
      ++k;
    }
  }
  const float gate = static_cast<float>(options_.tracker.gate_chi2);
  size_t k = 0;
  for (const SalientPoint& sp : measured.points) {
    while (probe_pixels_[k].u_px != sp.corner.u_px || probe_pixels_[k].v_px != sp.corner.v_px) ++k;
    const Prediction& p = predictions_[probe_prediction_[k++]];
    // One answer only: where the matcher finds several, the point may be any of them (or a
    // periodic alias of the candidate), so the measurement says nothing and the miss stands.
    if (sp.num_hypotheses != 1 || sp.first_hypothesis >= measured.hypotheses.size()) continue;
    const DisparityHypothesis& h = measured.hypotheses[sp.first_hypothesis];
    const float du = static_cast<float>(sp.corner.u_px) - p.u;
    const float dv = static_cast<float>(sp.corner.v_px) - p.v;
    const float dd = h.d_px - p.d;
    // Written so that a non-finite disparity from the probe fails the gate too.
    if (!(du * du * p.inv_var_u + dv * dv * p.inv_var_v + dd * dd * p.inv_var_d <= gate)) continue;
    if (!policy_->acceptsProbeAnswer(h)) continue;
    probed_[p.slot] = 1;
    ++frame_report_->probe_found;
  }
  return Status::ok();
}

Eigen::Isometry3d LandmarkDatabase::anchorCameraPose(const Landmark& l) const {
  const PoseRingEntry& e = pose_ring_[static_cast<uint32_t>(l.anchor.frame) % kPoseRingSize];
  if (e.frame == l.anchor.frame) return e.T_w_cl;
  return cameraPoseInWorld(l.anchor.odom_pose, T_b_cl_);
}

bool LandmarkDatabase::applyObservation(uint32_t slot,
                                        const DisparityHypothesis& h,
                                        const Corner& c) {
  Landmark& l = slots_[slot];
  if (!policy_->onAssociation(slot, l, h, c, frame_ctx_, *this)) {
    // Refused by the policy (consistency: the observation contradicts the candidate's anchor):
    // a miss, not an observation.
    contradicted_[slot] = 1;
    return false;
  }
  if (l.state == LandmarkState::kCandidate) {
    // Observations feed the refinement at confirmation; a confirmed landmark keeps none.
    Observation obs;
    obs.frame = frame_;
    obs.u_px = static_cast<float>(c.u_px);
    obs.v_px = static_cast<float>(c.v_px);
    obs.d_px = h.d_px;
    obs.odom_pose = pose_;
    if (static_cast<int>(l.observations.size()) >= options_.tracker.max_observations) {
      l.observations.erase(l.observations.begin() + 1);  // keep the anchor, drop the oldest other
    }
    l.observations.push_back(obs);
  }
  ++l.n_obs;
  l.last_seen_frame = frame_;
  l.path_at_last_seen_m = path_m_;
  l.turn_at_last_seen_rad = turn_rad_;
  l.consecutive_misses = 0;
  frame_obs_.push_back({slot, static_cast<float>(c.u_px), static_cast<float>(c.v_px), h.d_px});
  if (l.state == LandmarkState::kConfirmed) {
    confirmed_obs_.push_back(
        {l.id, l.p_w, static_cast<float>(c.u_px), static_cast<float>(c.v_px), h.d_px});
  }
  if (const auto p_cl = triangulateRectified(rig_, Eigen::Vector2d(c.u_px, c.v_px), h.d_px)) {
    if (!(map_frame_predictions_ && l.state == LandmarkState::kConfirmed)) {
      l.p_w_last = T_w_cl_ * *p_cl;
      hot_[slot].p_w_last = l.p_w_last;
    }
    policy_->onMeasured(slot, l, *p_cl);
  }
  return true;
}

}  // namespace twocam::landmarks
