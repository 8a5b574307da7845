#pragma once
/// The maths of the landmark database as free functions: prediction of a landmark's stereo
/// measurement, the gate's uncertainty from the odometry noise model, the evidence of a hit or a
/// miss, rival normalisation, parallax, and the SVO depth-seed update used by the inlier-ratio
/// baseline. Derivations: docs/landmarks.md.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/frames.h"
#include "common/odometry_noise.h"
#include "common/rig.h"
#include "landmarks/options.h"

namespace twocam::landmarks {

/// Pose of the left camera in the odometry world frame for an odometry pose: T_w_cl = T_w_b T_b_cl.
Eigen::Isometry3d cameraPoseInWorld(const Pose2& odom_pose, const Eigen::Isometry3d& T_b_cl);

/// Stereo measurement (u, v, d) [px] of a point given in the left camera frame.
/// Returns false when the point is not in front of the camera (z <= 0).
bool projectStereo(const StereoRig& rig, const Eigen::Vector3d& p_cl, Eigen::Vector3d* uvd);

/// Standard deviations of a predicted stereo measurement [px].
struct MeasurementSigma {
  double u_px = 0.0;
  double v_px = 0.0;
  double d_px = 0.0;
};

/// Uncertainty of the prediction (u, v, d) of a point at depth z_m after the robot drove
/// path_m and turned turn_rad (absolute) since the point was last observed, with sigma_t and
/// sigma_yaw the accumulated odometry error (common/odometry_noise.h, accumulatedOdometrySigma):
///   sigma_u^2 = sigma_px^2 + (fx sigma_yaw)^2 + ((fx + |u - cx|) sigma_t / z)^2
///   sigma_v^2 = sigma_px^2 + (|v - cy| sigma_t / z)^2
///   sigma_d^2 = sigma_dpx^2 + (d sigma_t / z)^2
/// A heading error moves every point sideways by fx sigma_yaw; a translation error along the
/// optical axis scales the offset from the principal point and the disparity by sigma_t / z, and
/// one across it shifts u by fx sigma_t / z.
MeasurementSigma predictionSigma(const TrackerOptions& options,
                                 const StereoRig& rig,
                                 const Eigen::Vector3d& uvd,
                                 double z_m,
                                 double path_m,
                                 double turn_rad);

/// The same for a given pose error: sigma_t and sigma_yaw of the predicting pose relative to the
/// landmark's position (predictionSigma passes the odometry error since the landmark was seen).
MeasurementSigma predictionSigmaFor(const TrackerOptions& options,
                                    const StereoRig& rig,
                                    const Eigen::Vector3d& uvd,
                                    double z_m,
                                    const OdometryErrorSigma& pose_error);

/// phantom_llr of a phantom whose real point would be behind the camera [nats].
constexpr double kPhantomImpossible = 1e3;

/// A re-observation compared with the candidate's anchor (docs/landmarks.md, "anchor check").
struct AnchorCheck {
  /// Squared Mahalanobis distance of the observed (u, v, d) from the anchor's prediction ((v, d)
  /// without anchor_check_columns).
  double mahalanobis2 = 0.0;
  /// True when the motion since the anchor can expose a spurious match: were the real point on
  /// the anchor ray at d_anchor +- max(verify_min_offset_px, verify_relative_offset d_anchor),
  /// a periodic-texture phantom of it (disparity a fixed multiple of the real one) would now be
  /// predicted at least verify_chi2 away from the candidate's own prediction. Decides how much
  /// a consistent hit counts (ConsistencyOptions::max_hit_evidence or stability_evidence).
  bool discriminative = false;
  /// Log-likelihood ratio [nats] of the observation for the candidate against each of those two
  /// phantoms (disparity below, above): 0.5 (m2 to the phantom's prediction - mahalanobis2),
  /// with the same sigmas. Summed over a candidate's consistent re-observations it decides its
  /// verification (ConsistencyOptions::verify_llr). A phantom whose real point would be behind
  /// the camera cannot exist: kPhantomImpossible.
  double phantom_llr[2] = {0.0, 0.0};
  /// False when the anchor point is behind the current camera (no prediction).
  bool valid = false;
};

/// Predicts the observation (u, v, d) [px] of the anchor's triangulation through the odometry
/// pose T_cl_w of the current frame and compares it with the observed (u_px, v_px, d_px). The
/// column counts only with options.anchor_check_columns: its sigma carries the heading error
/// (fx sigma_yaw), which shifts every column alike and grows with the angle turned, while rows
/// and disparities hardly depend on it. The sigmas combine the anchor's pixel and disparity noise
/// (propagated by re-projecting the anchor ray at d_anchor +- disparity_sigma), the observation
/// noise, and the odometry translation and heading error since the anchor (path_m, turn_rad).
///
/// phantom_d_px, when given, holds the two disparities [px] (below, above the anchor's) at which
/// the real point would sit for AnchorCheck::phantom_llr, instead of the generic offsets; a
/// value <= 0 means no phantom on that side (its phantom_llr is kPhantomImpossible).
/// AnchorCheck::discriminative always uses the generic offsets.
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
                               const float* phantom_d_px = nullptr);

/// Log-likelihood ratio [nats] of a landmark being real given that a hypothesis fell into its
/// gate: log(detection_prob / p_false_hit), capped at max_evidence (hits are not independent).
double hitEvidence(double detection_prob, double p_false_hit, double max_evidence);

/// Log-likelihood ratio [nats] given that nothing fell into the gate of a visible landmark:
/// log((1 - detection_prob) / (1 - p_false_hit)), always <= 0 for p_false_hit < detection_prob.
double missEvidence(double detection_prob, double p_false_hit);

/// Existence probabilities of mutually exclusive rivals (at most one real) from their prior
/// masses pi_i and evidence L_i: P_i = pi_i e^{L_i} / (pi_0 + extra + sum_j pi_j e^{L_j}), where
/// pi_0 is the prior of "none of them is real" and extra the mass of members that left the group.
/// Computed with the largest exponent factored out so it cannot overflow.
void normaliseRivals(const double* prior,
                     const double* evidence,
                     int n,
                     double none_prior,
                     double extra_mass,
                     double* probability);

/// Existence probability of a landmark without rivals from its prior mass pi and evidence L:
/// pi e^L / (pi e^L + none_mass). Evidence grows with every counted hit, so a landmark seen in a
/// few hundred frames takes e^L beyond the range of a double; the probability is then 1 (the
/// none mass is negligible), never inf / inf.
double lonePosterior(double prior, double evidence, double none_mass);

/// Angle [rad] at point p between the rays from camera centres c1 and c2 (0 when degenerate).
double parallaxAngle(const Eigen::Vector3d& p,
                     const Eigen::Vector3d& c1,
                     const Eigen::Vector3d& c2);

/// SVO's depth filter (Vogiatzis and Hernandez 2011; Forster et al. 2014): a Gaussian x Beta
/// posterior over the inverse depth mu (variance sigma2) and the inlier ratio Beta(a, b), updated
/// with a measurement x of variance tau2; outliers are uniform over [0, range].
/// Returns false (seed unchanged) when the update is numerically degenerate.
struct SvoSeed {
  double mu = 0.0;
  double sigma2 = 1.0;
  double a = 10.0;
  double b = 10.0;
  double range = 1.0;
};
bool updateSvoSeed(double x, double tau2, SvoSeed* seed);

}  // namespace twocam::landmarks
