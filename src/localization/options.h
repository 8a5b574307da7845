#pragma once
/// Options of the visual pose correction (localization/pose_update.h). Model and defaults:
/// docs/localization.md.

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/status.h"

namespace twocam::localization {

/// Where a run's poses come from (`--localization`, config `localization.mode`).
enum class Mode {
  kOdometry,  ///< dead reckoning: the wheel-odometry pose as logged
  kPnp,       ///< vision only: OpenCV solvePnPRansac frame-to-map on the same associations
  kFused,     ///< odometry prediction corrected by the robust pose update (pose_update.h)
};
const char* modeName(Mode mode);
/// "odometry" | "pnp" | "fused"; an error lists them.
Status parseMode(const std::string& name, Mode* mode);

struct PoseUpdateOptions {
  /// Fewest confirmed landmarks observed in a frame for a visual correction [-]; with fewer the
  /// pose stays the odometry prediction and its covariance grows. Six observations give 18
  /// residuals for 6 unknowns, enough for the Huber loss to outvote one wrong association.
  int min_landmarks = 6;
  /// Standard deviation of an observed landmark's column and row [px] and disparity [px]. The
  /// tracker's pixel and disparity sigmas (landmarks.tracker), plus the error of the map point
  /// itself seen from another place, hence a little wider.
  double pixel_sigma_px = 1.0;
  double disparity_sigma_px = 1.0;
  /// Scale of the Cauchy loss on the normalised stereo residuals [sigma]. A redescending loss:
  /// a wrong association (a neighbouring corner, a periodic alias) is many sigma off and its pull
  /// falls as 1/r, where under a Huber loss it stays constant. On office (one loop) Huber at 2
  /// sigma gave ATE 0.162 m, worse than odometry's 0.122 m; Cauchy at 1 sigma 0.012 m
  /// (docs/localization.md).
  double cauchy_sigma = 1.0;
  /// Squared normalised residual (3 dof) above which an observation is an outlier: not counted
  /// as used and not in the covariance [-]. 11.34 = chi-square(3) 99 %.
  double inlier_chi2 = 11.34;
  /// Soft planar prior: per-frame standard deviation of the height change [m] and of the roll
  /// and pitch change [rad] relative to the prediction. Small for a robot on a floor; a car on
  /// a sloped road (KITTI) needs more.
  double planar_sigma_m = 0.005;
  double planar_sigma_rad = 0.005;
  /// Gauss-Newton iterations of the Ceres solve [-].
  int max_iterations = 10;
  /// Most observations in the solve [-]: with more, an evenly strided subset of them in the
  /// database's order (deterministic); the solve's cost is linear in them. 0 = all, the
  /// default: 200 made the office localisation stage 2.5x faster (1.7 against 4.2 ms median)
  /// but its ATE 0.023 m against 0.019 m (docs/experiments/2026-12-03-localization-gates.md).
  int max_observations = 0;

  /// Each field in range; messages are prefixed with `prefix` (e.g. "localization.").
  [[nodiscard]] Status validate(const char* prefix = "") const;
};

struct SlipTestOptions {
  /// Measured steps over which odometry's motion is compared with the visual estimates' [-]
  /// (localization/slip_test.h): the slip's and one that confirms it. Each further step adds
  /// its noise to the sum while a slip is one step (with 3, office_loops' 3 cm and 3 degree
  /// slip in a turn tested 16.0 with noise seed 2).
  int window_frames = 2;
  /// Chi-square (3 dof) of that difference above which the window holds an odometry outlier
  /// [-]. 16.27 = chi-square(3) 99.9 %.
  double chi2 = 16.27;

  [[nodiscard]] Status validate(const char* prefix = "") const;
};

struct PoseSearchOptions {
  /// The slip search (localization/pose_search.h): run the check and, when it fails, the search
  /// (fused mode only).
  bool enabled = true;
  /// With enabled: the earlier map checks the pose too (pipeline/pipeline.h, "re-anchoring"):
  /// when the check against the recent reference finds nothing, the same search runs against
  /// the confirmed landmarks predicted in view but not associated in the last frame and not
  /// seen within reference_frames, the max_reference best observed of them.
  bool reanchor = true;
  /// With enabled: when the prediction fails the check and a heading within its error passes
  /// it (the odometry step's heading error in a turn), the landmark database predicts and gates
  /// at the pose the reference landmarks measured (the prediction corrected by
  /// PoseSearchResult::step), not at the prediction; the update's prior stays the prediction
  /// (localization/pose_search.h, associationPose). false: the database always uses the
  /// prediction (or the search's accepted pose).
  bool associate_at_step = true;
  /// Largest pose error the search covers: position [m] and heading [deg] per axis. The slips
  /// the issue names are 3-20 cm and 1-10 degrees; a little more leaves room for the
  /// prediction's own error.
  double max_slip_m = 0.25;
  double max_slip_deg = 12.0;
  /// One-to-one match of a landmark's projection with a hypothesis: pixel distance per axis [px]
  /// and disparity difference [px]. About two sigma of a confirmed landmark's reprojection
  /// (localization.update's pixel_sigma_px = 1 px) plus the predicted pose's error in normal
  /// frames.
  double match_px = 2.5;
  double match_disparity_px = 1.5;
  /// The check: the prediction holds when this fraction of the reference landmarks in view
  /// match, both counted beyond the matches chance would give (PoseSearch::chanceMatches) [-].
  /// Frame to frame about 0.6-0.9 of them are detected and matched again (docs/localization.md);
  /// after a slip of a degree or more, a few percent.
  double trigger_fraction = 0.4;
  /// The check also tries headings within local_sigmas x the prediction's yaw sigma [-] (the
  /// odometry step's own error); the best one's matches are the bar a searched pose must
  /// clear by win_ratio (against the earlier map, one passing the check ends it).
  double local_sigmas = 3.0;
  /// A searched pose must explain at least this fraction of the reference landmarks in view,
  /// beyond chance as the check [-]. On office_loops 0.63-0.9 of them matched at a slip's true
  /// pose and 0.45-0.52 at poses that rotate about a wall (a rotation and a sideways shift that
  /// cancel on one plane), counted raw; beyond office's 5-10 % of chance that is 0.59 and more
  /// against 0.47 and less. 0.6 beyond chance refused a true pose at 0.58 (a held-out office
  /// world, docs/experiments/2026-12-07-matches-beyond-chance.md).
  double accept_fraction = 0.55;
  /// The reference landmarks: those the last reference_frames visual updates used [-]. One
  /// frame is enough in a textured corridor; after a blank turn (office_loops' 8 degree slip
  /// falls in one) the last frame saw only a handful.
  int reference_frames = 10;
  /// Refused as ambiguous when a searched pose two vote bins or more from the winner explains
  /// at least this fraction of the winner's matches with matches it does not share with the
  /// winner (all its matches when re-anchoring) [-] (a periodic texture's alias).
  double ambiguity_ratio = 0.8;
  /// Fewest reference landmarks in view for a check or a search [-].
  int min_reference = 12;
  /// Most reference landmarks the search uses (an even stride over them) [-].
  int max_reference = 120;
  /// Acceptance: fewest matches of the searched pose [-] and how many times the prediction's
  /// score it must reach [-]. With 10, a periodic floor (repetitive, seed 3) gave a tile alias
  /// from a handful of landmarks in view (ATE 0.44 m against 0.011 m); the slips' poses on
  /// office_loops and garden were found with 26 matches and more.
  int min_matches = 20;
  double win_ratio = 2.0;
  /// Vote histogram bins: position [m] and heading [deg]. The histogram spans the box,
  /// votePositionHalfBins() and voteHeadingHalfBins() on either side of zero, at most
  /// kMaxVoteBins bins in all (validate()).
  double vote_m = 0.02;
  double vote_deg = 0.5;
  static constexpr int64_t kMaxVoteBins = int64_t{1} << 22;
  [[nodiscard]] int64_t votePositionHalfBins() const {
    return static_cast<int64_t>(std::ceil(max_slip_m / vote_m));
  }
  [[nodiscard]] int64_t voteHeadingHalfBins() const {
    return static_cast<int64_t>(std::ceil(max_slip_deg / vote_deg));
  }
  /// Bins scored [-].
  int scored_bins = 12;
  /// Single-landmark votes: at each heading bin every candidate of a reference landmark votes
  /// for the translation that puts the landmark on it, a landmark at most once per bin, so that
  /// a bin's count is about the matches its pose would score (a pair's votes grow with the
  /// square of the candidates, and dense ground texture's chance pairs can outnumber the true
  /// pose's). The fullest point_bins of them not already among the pair bins are scored too
  /// (0: off) [-].
  int point_bins = 6;
  /// Refused as ambiguous also when the winner's lead over the best distinct rival is within
  /// ambiguity_sigmas x sqrt(winner + rival) matches (a sign test: were the two poses equally
  /// good, each of those matches would fall to either; 1.645 is one-sided 5 %) [-]. With few
  /// references (a blank turn: 26 matches against 20) the ratio alone lets a lucky pose pass.
  double ambiguity_sigmas = 1.645;

  [[nodiscard]] Status validate(const char* prefix = "") const;
};

struct PnpOptions {
  /// RANSAC inlier threshold on the reprojection error [px] and iterations [-].
  double reprojection_px = 2.0;
  int iterations = 100;
  [[nodiscard]] Status validate(const char* prefix = "") const;
};

/// The `localization` section of the run config.
struct LocalizationOptions {
  /// Fused: measured better than odometry (ATE 0.10x-0.79x) and than pnp on every world
  /// (docs/localization.md); odometry reproduces dead reckoning.
  Mode mode = Mode::kFused;
  /// pnp, fused: confirmed landmarks are gated by the estimate's predicted covariance (never
  /// wider than the odometry gates; the odometry gates again when too few associate:
  /// LandmarkDatabase::setPredictionSigma). false: odometry gates, as in odometry mode.
  bool estimate_gates = true;
  PoseUpdateOptions update;
  SlipTestOptions slip;
  PoseSearchOptions search;
  PnpOptions pnp;
  /// Messages name the key: "localization.update.min_landmarks = 1; must be in [3, 100000]".
  [[nodiscard]] Status validate() const;
};

}  // namespace twocam::localization
