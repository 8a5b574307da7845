#pragma once
/// Relocalisation in a map (issue 25 part 4, docs/relocalization.md): the pose of one stereo
/// frame in the map's frame m from nothing but appearance and geometry, with no prior pose.
///  1. Match every frame point's descriptor to the map landmarks' (nearest neighbour, distance
///     bound and a ratio test against the second-nearest landmark that is not the same place).
///  2. Solve T_cl_m with OpenCV's PnP RANSAC (AP3P minimal sets, then Levenberg-Marquardt on
///     the inliers), seeded; keep the matches that agree with the pose in (u, v) and disparity.
///     Then a Gauss-Newton refinement on the inliers' (u, v, d) and the position's covariance.
///  3. 3-D check: the inliers' stereo-triangulated points agree with their map points.
///  4. Verification: predict every other landmark the pose puts in view; of the frame points
///     (not inliers) with a predicted landmark near their pixel, count those for which one such
///     landmark also has their disparity and a similar descriptor. A pose found from a few
///     chance matches in a wrong place predicts landmarks that are not there.
/// Accepted only when every test passes (the thresholds are RelocalizationOptions).
///
/// Frames: m = the map's frame, cl = left camera optical frame, b = body (rig.T_b_cl).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "common/rig.h"
#include "common/status.h"
#include "frontend/descriptors.h"

namespace twocam::localization {

/// A point of the frame to relocalise: a left pixel with its stereo disparity and descriptor.
struct RelocalizationPoint {
  double u_px = 0.0;
  double v_px = 0.0;
  double d_px = 0.0;  ///< > 0
  frontend::Descriptor descriptor;
};

/// A landmark of the map: its position in the map frame and its descriptor.
struct MapLandmark {
  uint64_t id = 0;
  Eigen::Vector3d p_m = Eigen::Vector3d::Zero();
  frontend::Descriptor descriptor;
};

struct RelocalizationOptions {
  /// Largest descriptor distance of a match: ORB Hamming bits / 256. 0.25 = 64 of 256 bits,
  /// about where ORB's distance distributions of true and false matches cross.
  double max_orb_distance = 0.25;
  /// Largest descriptor distance of a match for the patch: 1 - NCC. 0.3 = NCC >= 0.7.
  double max_patch_distance = 0.3;
  /// Lowe's ratio: best distance < ratio * second best. 0.8 as in Lowe (2004).
  double ratio = 0.8;
  /// Landmarks within this distance of the best one are the same place (a map holds a corner
  /// several times, from several frames) and are not the ratio test's second best [m].
  double same_place_m = 0.1;
  /// PnP RANSAC reprojection threshold [px]: the simulator's corners are within ~1 px.
  double reprojection_px = 2.0;
  /// Largest disparity error of a match kept as inlier after the solve [px].
  double inlier_disparity_px = 1.5;
  /// RANSAC iterations and confidence (cv::solvePnPRansac).
  int ransac_iterations = 1000;
  double ransac_confidence = 0.999;
  /// Seed of OpenCV's RNG for RANSAC; the same seed gives the same result.
  uint64_t seed = 1;
  /// Pixel and disparity noise assumed for the pose's covariance [px], and the largest standard
  /// deviation of the camera position (its worst direction) a pose may have [m]. A view of
  /// only far points fixes the rotation but not the range; such a frame is refused and a
  /// later one taken. 1 px: a corner at an integer pixel, a sub-pixel disparity within ~0.5 px.
  double pose_sigma_px = 1.0;
  double max_position_sigma_m = 0.02;
  /// Fewest inliers for a pose. 15: a wrong place rarely gathers 15 consistent chance matches.
  int min_inliers = 15;
  /// 3-D check: an inlier's triangulated point agrees with its map point when closer than
  /// point_tolerance_m plus the depth error of point_disparity_px of disparity at its depth.
  double point_tolerance_m = 0.05;
  double point_disparity_px = 1.0;
  /// Fewest inliers passing the 3-D check [fraction of the inliers].
  double min_point_fraction = 0.8;
  /// Verification: a frame point is checked when a predicted landmark lies within verify_px of
  /// it, and verified when one of those is also within verify_disparity_px of its disparity
  /// with a descriptor within the match distance [px].
  double verify_px = 3.0;
  double verify_disparity_px = 1.5;
  /// Landmarks are predicted only in front of the camera beyond this depth, with their pixel
  /// at least this far inside the image [m], [px].
  double min_depth_m = 0.3;
  int image_margin_px = 16;
  /// Fewest verified frame points (besides the inliers), and the fewest verified_fraction.
  int min_verified = 10;
  double min_verified_fraction = 0.2;

  [[nodiscard]] Status validate(const char* prefix = "relocalization.") const;
};

struct RelocalizationMatch {
  uint32_t point = 0;     ///< index into the frame points
  uint32_t landmark = 0;  ///< index into the map landmarks
  double distance = 0.0;  ///< descriptor distance (frontend::descriptorDistance)
  bool inlier = false;
};

struct RelocalizationResult {
  /// The pose passed every test.
  bool found = false;
  /// Why not, when not found (for logs and the experiment).
  std::string reason;
  /// The pose (valid when pnp_solved, accepted only when found).
  bool pnp_solved = false;
  Eigen::Isometry3d T_m_cl = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_m_b = Eigen::Isometry3d::Identity();
  std::vector<RelocalizationMatch> matches;
  int inliers = 0;
  /// Standard deviation of the camera position in its worst direction [m] (from the stereo
  /// refinement's Jacobian with pose_sigma_px).
  double position_sigma_m = 0.0;
  /// Inliers whose triangulated point agrees with the map (3-D check).
  int points_agreeing = 0;
  /// Verification: frame points (not inliers) with a predicted landmark near them, and those
  /// whose nearby landmark also agrees in disparity and descriptor.
  int checked = 0;
  int verified = 0;
  /// The verification score (inliers + verified) / (inliers + checked): of the frame points
  /// near a landmark the pose predicts, the fraction that agree with it (an inlier agrees by
  /// construction). A wrong pose has few inliers and verifies almost nothing.
  double verified_fraction = 0.0;
};

/// Relocalises one frame in the map. Errors for invalid options, a descriptor kind that differs
/// between the frame and the map, or a non-positive disparity; otherwise OK with result->found
/// saying whether the frame was placed. Deterministic for a given options.seed.
Status relocalize(const StereoRig& rig,
                  const std::vector<RelocalizationPoint>& frame,
                  const std::vector<MapLandmark>& map,
                  const RelocalizationOptions& options,
                  RelocalizationResult* result);

}  // namespace twocam::localization
