#include "support/synthetic_stream.h"

#include <algorithm>
#include <cmath>

#include "common/odometry_noise.h"

namespace twocam::test {

StereoRig SyntheticStream::defaultRig() {
  StereoRig rig;
  rig.width_px = 640;
  rig.height_px = 480;
  rig.fx_px = rig.fy_px = 500.0;
  rig.cx_px = 319.5;
  rig.cy_px = 239.5;
  rig.baseline_m = 0.12;
  rig.T_b_cl = Eigen::Isometry3d::Identity();
  rig.T_b_cl.linear() = opticalRotationFromYawPitch(0.0, 5.0 * M_PI / 180.0);
  rig.T_b_cl.translation() = Eigen::Vector3d(0.1, 0.06, 0.5);
  return rig;
}

SyntheticStream::SyntheticStream(const StereoRig& rig, const SyntheticStreamOptions& options)
    : rig_(rig), options_(options), rng_(options.seed) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double perimeter = 4.0 * (options.half_x_m + options.half_y_m);
  for (int i = 0; i < options.num_points; ++i) {
    double s = unit(rng_) * perimeter;
    Eigen::Vector3d p;
    const double z = 0.2 + 2.3 * unit(rng_);
    const double wx = 2.0 * options.half_x_m;
    const double wy = 2.0 * options.half_y_m;
    if (s < wx) {
      p = {-options.half_x_m + s, -options.half_y_m, z};
    } else if ((s -= wx) < wy) {
      p = {options.half_x_m, -options.half_y_m + s, z};
    } else if ((s -= wy) < wx) {
      p = {options.half_x_m - s, options.half_y_m, z};
    } else {
      s -= wx;
      p = {-options.half_x_m, options.half_y_m - s, z};
    }
    points_w_.push_back(p);
    period_m_.push_back(unit(rng_) < options.periodic_rival_fraction ? 0.05 + 0.25 * unit(rng_)
                                                                     : 0.0);
  }
  // Start on the circle at angle 0, heading tangentially (counter-clockwise).
  true_pose_ = {options.circle_radius_m, 0.0, M_PI / 2.0};
  odom_pose_ = true_pose_;
}

void SyntheticStream::next(SyntheticFrame* out) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  if (frame_ > 0) {
    const double ds = options_.speed_mps / options_.rate_hz;
    const double dyaw = ds / options_.circle_radius_m;
    angle_rad_ += dyaw;
    true_pose_ = {options_.circle_radius_m * std::cos(angle_rad_),
                  options_.circle_radius_m * std::sin(angle_rad_),
                  angle_rad_ + M_PI / 2.0};
    const double ds_odo = (1.0 + options_.odom_scale_error) * ds +
                          randomIncrementSigma(options_.odom_sigma_per_m, ds) * normal(rng_);
    const double dyaw_odo = dyaw / (1.0 + options_.odom_wheel_base_error) +
                            randomIncrementSigma(options_.odom_sigma_per_rad, dyaw) * normal(rng_);
    const double mid = odom_pose_.yaw_rad + 0.5 * dyaw_odo;
    odom_pose_.x_m += ds_odo * std::cos(mid);
    odom_pose_.y_m += ds_odo * std::sin(mid);
    odom_pose_.yaw_rad += dyaw_odo;
  }
  out->frame = frame_;
  out->t_ns = 1'000'000'000LL + static_cast<int64_t>(std::llround(frame_ * 1e9 / options_.rate_hz));
  out->true_pose = true_pose_;
  out->odom_pose = odom_pose_;
  out->hypotheses.clear();
  out->hypotheses.t_ns = out->t_ns;
  out->hypothesis_true.clear();
  out->hypothesis_kind.clear();
  out->hypothesis_point.clear();

  const Eigen::Isometry3d T_cl_w = (toIsometry(true_pose_) * rig_.T_b_cl).inverse();
  const double fb = rig_.fx_px * rig_.baseline_m;
  for (size_t i = 0; i < points_w_.size(); ++i) {
    const Eigen::Vector3d p = T_cl_w * points_w_[i];
    if (p.z() < 0.3) continue;
    const double u = rig_.cx_px + rig_.fx_px * p.x() / p.z();
    const double v = rig_.cy_px + rig_.fy_px * p.y() / p.z();
    const double d = fb / p.z();
    const int ui = static_cast<int>(std::lround(u));
    const int vi = static_cast<int>(std::lround(v));
    if (ui < 8 || vi < 8 || ui >= rig_.width_px - 8 || vi >= rig_.height_px - 8) continue;
    if (d < 1.0 || d > options_.max_disparity_px) continue;
    if (unit(rng_) >= options_.detection_prob) continue;
    // Candidate disparities: the real one and the rivals; rank by a drawn cost.
    struct Cand {
      float d;
      bool real;
      float cost;
      uint8_t kind;
    };
    Cand cands[4];
    int n = 0;
    cands[n++] = {
        static_cast<float>(d + options_.disparity_sigma_px * normal(rng_)), true, 0.0f, 0};
    // Drawn only when asked for, so that streams without twins stay as they were.
    if (options_.twin_prob > 0.0 && unit(rng_) < options_.twin_prob) {
      const double offset = (unit(rng_) < 0.5 ? -1.0 : 1.0) * 0.6 * unit(rng_);
      cands[n++] = {static_cast<float>(cands[0].d + offset), true, 0.0f, 0};
    }
    if (period_m_[i] > 0.0) {
      const double d_wrong = d + rig_.fx_px * period_m_[i] / p.z();
      if (d_wrong <= options_.max_disparity_px)
        cands[n++] = {static_cast<float>(d_wrong), false, 0.0f, 1};
    }
    if (unit(rng_) < options_.random_rival_prob) {
      const double d_rand = 1.0 + unit(rng_) * (options_.max_disparity_px - 1.0);
      if (std::abs(d_rand - d) > 2.0) cands[n++] = {static_cast<float>(d_rand), false, 0.0f, 2};
    }
    const bool rival_wins = n > 1 && unit(rng_) < options_.rival_wins_prob;
    for (int k = 0; k < n; ++k) {
      cands[k].cost = static_cast<float>(100.0 + 100.0 * unit(rng_));
      if (cands[k].real != rival_wins) cands[k].cost -= 100.0f;  // the winner costs less
    }
    std::sort(cands, cands + n, [](const Cand& a, const Cand& b) { return a.cost < b.cost; });
    SalientPoint sp;
    sp.corner = {ui, vi, 1.0f};
    sp.first_hypothesis = static_cast<uint32_t>(out->hypotheses.hypotheses.size());
    sp.num_hypotheses = static_cast<uint32_t>(n);
    sp.complete = options_.complete_lists;
    const uint32_t point_index = static_cast<uint32_t>(out->hypotheses.points.size());
    out->hypotheses.points.push_back(sp);
    for (int k = 0; k < n; ++k) {
      DisparityHypothesis h;
      h.d_px = cands[k].d;
      h.cost = cands[k].cost;
      h.point_index = point_index;
      h.rank = static_cast<uint8_t>(k);
      // A periodic rival passes the left-right check like the real match does.
      h.lr_consistent = k == 0;
      out->hypotheses.hypotheses.push_back(h);
      out->hypothesis_true.push_back(cands[k].real ? 1 : 0);
      out->hypothesis_kind.push_back(cands[k].kind);
      out->hypothesis_point.push_back(static_cast<int32_t>(i));
    }
  }
  ++frame_;
}

}  // namespace twocam::test
