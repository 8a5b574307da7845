#include "landmarks/landmark_model.h"

#include <algorithm>
#include <cmath>

namespace twocam::landmarks {

Eigen::Isometry3d cameraPoseInWorld(const Pose2& odom_pose, const Eigen::Isometry3d& T_b_cl) {
  return toIsometry(odom_pose) * T_b_cl;
}

bool projectStereo(const StereoRig& rig, const Eigen::Vector3d& p_cl, Eigen::Vector3d* uvd) {
  if (!(p_cl.z() > 0.0)) return false;
  const double inv_z = 1.0 / p_cl.z();
  *uvd = Eigen::Vector3d(rig.cx_px + rig.fx_px * p_cl.x() * inv_z,
                         rig.cy_px + rig.fy_px * p_cl.y() * inv_z,
                         rig.fx_px * rig.baseline_m * inv_z);
  return true;
}

MeasurementSigma predictionSigma(const TrackerOptions& options,
                                 const StereoRig& rig,
                                 const Eigen::Vector3d& uvd,
                                 double z_m,
                                 double path_m,
                                 double turn_rad) {
  return predictionSigmaFor(
      options, rig, uvd, z_m, accumulatedOdometrySigma(options.odometry_noise, path_m, turn_rad));
}

MeasurementSigma predictionSigmaFor(const TrackerOptions& options,
                                    const StereoRig& rig,
                                    const Eigen::Vector3d& uvd,
                                    double z_m,
                                    const OdometryErrorSigma& pose_error) {
  const double sigma_t = pose_error.trans_m;
  const double sigma_yaw = pose_error.yaw_rad;
  const double t_over_z = sigma_t / std::max(z_m, 1e-3);
  const double du_t = (rig.fx_px + std::abs(uvd.x() - rig.cx_px)) * t_over_z;
  const double du_r = rig.fx_px * sigma_yaw;
  const double dv_t = std::abs(uvd.y() - rig.cy_px) * t_over_z;
  const double dd_t = uvd.z() * t_over_z;
  const double px2 = options.pixel_sigma_px * options.pixel_sigma_px;
  MeasurementSigma out;
  out.u_px = std::sqrt(px2 + du_r * du_r + du_t * du_t);
  out.v_px = std::sqrt(px2 + dv_t * dv_t);
  out.d_px = std::sqrt(options.disparity_sigma_px * options.disparity_sigma_px + dd_t * dd_t);
  return out;
}

AnchorCheck checkAgainstAnchor(const LandmarkOptions& options,
                               const StereoRig& rig,
                               const Eigen::Isometry3d& T_w_cl_anchor,
                               double anchor_u_px,
                               double anchor_v_px,
                               double anchor_d_px,
                               const Eigen::Isometry3d& T_cl_w,
                               double u_px,
                               double v_px,
                               double d_px,
                               double path_m,
                               double turn_rad,
                               const float* phantom_d_px) {
  AnchorCheck out;
  const Eigen::Isometry3d T_cl_cla = T_cl_w * T_w_cl_anchor;
  const Eigen::Vector2d uv_a(anchor_u_px, anchor_v_px);
  // Prediction of the anchor ray at disparity d (nullopt when behind either camera).
  const auto predict = [&](double d, Eigen::Vector3d* uvd, double* x_over_z) {
    if (!(d > 0.0)) return false;
    const auto p_a = triangulateRectified(rig, uv_a, d);
    if (!p_a) return false;
    const Eigen::Vector3d p = T_cl_cla * *p_a;
    if (!projectStereo(rig, p, uvd)) return false;
    if (x_over_z != nullptr) *x_over_z = p.x() / p.z();
    return true;
  };
  Eigen::Vector3d nominal;
  double x_over_z = 0.0;
  if (!predict(anchor_d_px, &nominal, &x_over_z)) return out;
  const double fb = rig.fx_px * rig.baseline_m;
  const double z = fb / nominal.z();
  const OdometryErrorSigma odo =
      accumulatedOdometrySigma(options.tracker.odometry_noise, path_m, turn_rad);
  const double sigma_t = odo.trans_m;
  const double sigma_yaw = odo.yaw_rad;
  // Anchor disparity noise, propagated by re-projecting the ray at d +- sigma.
  Eigen::Vector3d plus, minus;
  double var_u_anchor = 0.0;
  double var_v_anchor = 0.0;
  double var_d_anchor = 0.0;
  if (predict(anchor_d_px + options.tracker.disparity_sigma_px, &plus, nullptr) &&
      predict(anchor_d_px - options.tracker.disparity_sigma_px, &minus, nullptr)) {
    var_u_anchor = 0.25 * (plus.x() - minus.x()) * (plus.x() - minus.x());
    var_v_anchor = 0.25 * (plus.y() - minus.y()) * (plus.y() - minus.y());
    var_d_anchor = 0.25 * (plus.z() - minus.z()) * (plus.z() - minus.z());
  } else {
    return out;  // the anchor's depth is too uncertain to predict anything
  }
  const double z_ratio = (fb / anchor_d_px) / z;  // anchor pixel noise scales with z_anchor / z
  const double px2 = options.tracker.pixel_sigma_px * options.tracker.pixel_sigma_px;
  const double dv_odo =
      std::abs(nominal.y() - rig.cy_px) * (sigma_t / z + std::abs(x_over_z) * sigma_yaw);
  const double dd_odo = nominal.z() * (sigma_t / z + std::abs(x_over_z) * sigma_yaw);
  const double var_v = px2 + px2 * z_ratio * z_ratio + var_v_anchor + dv_odo * dv_odo;
  const double var_d = options.tracker.disparity_sigma_px * options.tracker.disparity_sigma_px +
                       var_d_anchor + dd_odo * dd_odo;
  // Columns: a heading error shifts them all by fx sigma_yaw, a translation error across the
  // optical axis by fx sigma_t / z and one along it scales the offset from cx (as in the gate).
  const bool use_u = options.consistency.anchor_check_columns;
  const double du_odo = std::hypot(rig.fx_px * sigma_yaw,
                                   (rig.fx_px + std::abs(nominal.x() - rig.cx_px)) * sigma_t / z);
  const double var_u = px2 + px2 * z_ratio * z_ratio + var_u_anchor + du_odo * du_odo;
  const double eu = u_px - nominal.x();
  const double ev = v_px - nominal.y();
  const double ed = d_px - nominal.z();
  out.mahalanobis2 = ev * ev / var_v + ed * ed / var_d + (use_u ? eu * eu / var_u : 0.0);
  out.valid = true;
  // Discrimination: would a spurious match have been exposed by now? On a periodic texture the
  // spurious disparity stays a fixed multiple of the real one (the period is fixed in the world),
  // so if the real point sat on the anchor ray at disparity alt, this candidate would be seen at
  // the real point's row and at its disparity times d_anchor / alt.
  // The phantom of a real point at disparity alt: predicted where that point is, at its
  // disparity times d_anchor / alt (false when such a real point would be behind the camera).
  const auto phantom = [&](double alt, Eigen::Vector3d* uvd) {
    if (!predict(alt, uvd, nullptr)) return false;
    uvd->z() *= anchor_d_px / alt;
    return true;
  };
  const auto m2_from = [&](const Eigen::Vector3d& a, double u, double v, double d) {
    const double du = u - a.x();
    const double dv = v - a.y();
    const double dd = d - a.z();
    return dv * dv / var_v + dd * dd / var_d + (use_u ? du * du / var_u : 0.0);
  };
  const double offset = std::max(options.consistency.verify_min_offset_px,
                                 options.consistency.verify_relative_offset * anchor_d_px);
  const double generic[2] = {anchor_d_px - offset, anchor_d_px + offset};
  bool discriminative = true;
  for (int k = 0; k < 2; ++k) {
    out.phantom_llr[k] = kPhantomImpossible;
    Eigen::Vector3d p;
    if (phantom(generic[k], &p)) {
      if (m2_from(p, nominal.x(), nominal.y(), nominal.z()) < options.consistency.verify_chi2)
        discriminative = false;
      // The observation under the phantom hypothesis against under the candidate's.
      if (phantom_d_px == nullptr)
        out.phantom_llr[k] = 0.5 * (m2_from(p, u_px, v_px, d_px) - out.mahalanobis2);
    }
    if (phantom_d_px != nullptr && phantom_d_px[k] > 0.0f && phantom(phantom_d_px[k], &p)) {
      out.phantom_llr[k] = 0.5 * (m2_from(p, u_px, v_px, d_px) - out.mahalanobis2);
    }
  }
  out.discriminative = discriminative;
  return out;
}

double hitEvidence(double detection_prob, double p_false_hit, double max_evidence) {
  const double pf = std::clamp(p_false_hit, 1e-9, 1.0);
  return std::min(std::log(detection_prob / pf), max_evidence);
}

double missEvidence(double detection_prob, double p_false_hit) {
  const double pf = std::clamp(p_false_hit, 0.0, 0.999);
  return std::log((1.0 - detection_prob) / (1.0 - pf));
}

void normaliseRivals(const double* prior,
                     const double* evidence,
                     int n,
                     double none_prior,
                     double extra_mass,
                     double* probability) {
  double max_l = 0.0;  // the "none" and "extra" terms carry exponent 0
  for (int i = 0; i < n; ++i) max_l = std::max(max_l, evidence[i]);
  const double scale = std::exp(-max_l);
  double denom = (none_prior + extra_mass) * scale;
  for (int i = 0; i < n; ++i) {
    probability[i] = prior[i] * std::exp(evidence[i] - max_l);
    denom += probability[i];
  }
  for (int i = 0; i < n; ++i) probability[i] = denom > 0.0 ? probability[i] / denom : 0.0;
}

double lonePosterior(double prior, double evidence, double none_mass) {
  const double mass = prior * std::exp(evidence);
  if (!std::isfinite(mass)) return 1.0;
  return mass / (mass + none_mass);
}

double parallaxAngle(const Eigen::Vector3d& p,
                     const Eigen::Vector3d& c1,
                     const Eigen::Vector3d& c2) {
  const Eigen::Vector3d r1 = c1 - p;
  const Eigen::Vector3d r2 = c2 - p;
  const double n1 = r1.norm();
  const double n2 = r2.norm();
  if (n1 <= 0.0 || n2 <= 0.0) return 0.0;
  return std::atan2(r1.cross(r2).norm(), r1.dot(r2));
}

bool updateSvoSeed(double x, double tau2, SvoSeed* seed) {
  const double norm_var = seed->sigma2 + tau2;
  if (!(norm_var > 0.0) || !(seed->range > 0.0)) return false;
  const double s2 = 1.0 / (1.0 / seed->sigma2 + 1.0 / tau2);
  const double m = s2 * (seed->mu / seed->sigma2 + x / tau2);
  const double diff = x - seed->mu;
  const double gauss = std::exp(-0.5 * diff * diff / norm_var) / std::sqrt(2.0 * M_PI * norm_var);
  double c1 = seed->a / (seed->a + seed->b) * gauss;
  double c2 = seed->b / (seed->a + seed->b) / seed->range;
  const double norm = c1 + c2;
  if (!(norm > 0.0)) return false;
  c1 /= norm;
  c2 /= norm;
  const double ab = seed->a + seed->b;
  const double f = c1 * (seed->a + 1.0) / (ab + 1.0) + c2 * seed->a / (ab + 1.0);
  const double e = c1 * (seed->a + 1.0) * (seed->a + 2.0) / ((ab + 1.0) * (ab + 2.0)) +
                   c2 * seed->a * (seed->a + 1.0) / ((ab + 1.0) * (ab + 2.0));
  const double mu_new = c1 * m + c2 * seed->mu;
  const double sigma2_new =
      c1 * (s2 + m * m) + c2 * (seed->sigma2 + seed->mu * seed->mu) - mu_new * mu_new;
  const double denom = f - e / f;
  if (!(sigma2_new > 0.0) || !(std::abs(denom) > 1e-12) || !(f > 0.0)) return false;
  const double a_new = (e - f) / denom;
  const double b_new = a_new * (1.0 - f) / f;
  if (!(a_new > 0.0) || !(b_new > 0.0)) return false;
  seed->mu = mu_new;
  seed->sigma2 = sigma2_new;
  seed->a = a_new;
  seed->b = b_new;
  return true;
}

}  // namespace twocam::landmarks
