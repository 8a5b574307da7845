#pragma once
/// Pose search after a slip (docs/localization.md, "Slip search"). The database associates
/// confirmed landmarks inside gates round their predicted pixels; after a wheel slip the
/// prediction is off by more than its covariance says (a 3 degree slip moves every pixel by
/// ~26 px at fx = 500), the gates hold the wrong corners or none, and the update cannot see the
/// slip. The search does not trust the prediction:
///
///  1. Check. The reference landmarks (those the previous frame's update used) are projected
///     with the predicted pose and matched one-to-one to the frame's hypotheses within
///     match_px / match_disparity_px (each salient point explains at most one landmark). When at
///     least trigger_fraction of those in view match, the prediction holds: no search. Counts
///     and shares are taken beyond chance (chanceMatches: on dense texture a match window
///     holds a salient point with the right disparity at any pose).
///     Otherwise headings within local_sigmas x the prediction's yaw sigma are tried; the best
///     one's matches measure the step (below) and set the bar the search must clear, and the
///     search runs only when a winner could clear it (win_ratio x those matches, at most every
///     reference in view). A heading passing the check does not end it: after a slip of
///     position and heading it lines up the far points only.
///  2. Candidates. Each reference landmark's window is the box its projection sweeps over every
///     planar pose error up to (max_slip_m, max_slip_deg); every hypothesis in that box whose
///     stereo point has the landmark's height and range (within the slip and the disparity's
///     depth error) is a candidate.
///  3. Votes. Two landmarks far apart and one candidate each fix a planar pose error
///     (dx, dy, dyaw) when the candidates' distance equals the landmarks' (a rigid pair); each
///     rigid pair votes for its pose error in a histogram of vote_m x vote_m x vote_deg bins.
///  4. Scores. The fullest bins' poses are scored as in step 1, one-to-one, refined by a planar
///     least-squares fit to their matches and scored again; the best is refined further by the
///     step fit (pixels and disparity) while it explains more; a refit outside the box is not
///     taken (nothing was searched there). It is accepted when it
///     explains at least min_matches and at least win_ratio x as many landmarks as the
///     prediction or the best heading did (and at least accept_fraction of the landmarks in
///     its view), all beyond chance, and no pose two bins or more away reaches ambiguity_ratio
///     of its matches with matches of its own (those it does not share with the winner). The
///     winner's chance is the prediction's per reference in view times the references in view
///     of the winner: a pose turned towards more references draws more chance matches, and at
///     the right pose the ring round each projection holds its neighbours' true corners, so the
///     density there would count real structure as chance.
///
/// With WideSearch::kAfterHeadingSweep, steps 2-4 run only when a heading alone would pass the
/// check (for references that often fail it without the pose being wrong), a heading within
/// the prediction's error that passes it ends the check, and the winner is not refined.
///
/// Deterministic: no random draws (pairs are enumerated in a fixed order).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/rig.h"
#include "common/status.h"
#include "localization/options.h"

namespace twocam::localization {

struct PoseSearchResult {
  int reference = 0;         ///< reference landmarks in view of the prediction
  int prediction_score = 0;  ///< of them matched one-to-one at the prediction
  /// Matches chance alone would give at the prediction (PoseSearch::chanceMatches; with
  /// WideSearch::kAlways, else 0): the check's and the acceptance's counts are taken beyond it.
  double chance_score = 0.0;
  bool searched = false;  ///< the check failed and the search ran
  bool accepted = false;  ///< the search found a pose that explains decisively more
  int score = 0;          ///< matches at the accepted pose (0 when not accepted)
  /// Of the searched poses distinct from the winner, the most matches one holds; with
  /// WideSearch::kAlways only those the winner does not share (the same landmark on the same
  /// salient point).
  int rival_score = 0;
  /// Searched (accepted or not): the most matches of a searched pose, and its correction (the
  /// winner the acceptance tests judged).
  int best_score = 0;
  Pose2 best_correction;
  /// Searched with WideSearch::kAlways: the reference landmarks in view of that pose and the
  /// matches chance alone would give there; its acceptance counts beyond them (else 0).
  int best_reference = 0;
  double best_chance_score = 0.0;
  /// Planar pose error found, in the predicted body frame: T_w_b = T_w_b_pred * correction.
  Pose2 correction;
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();  ///< the pose to predict with
  /// The odometry step's error as the reference landmarks measure it: the planar correction of
  /// the prediction (T_w_b_pred * step) fitted to their one-to-one matches (at the accepted
  /// pose after a search, else at the prediction) by a robust Gauss-Newton on (u, v, d), its
  /// covariance, and the matches fitted. The reference landmarks are those the previous
  /// frame's pose was fitted to, so a map that disagrees with itself does not enter it: it is
  /// the frame-to-frame visual motion against odometry's, which the slip test reads.
  bool step_measured = false;
  Pose2 step;
  Eigen::Matrix3d step_cov = Eigen::Matrix3d::Zero();
  int step_matches = 0;
  /// The prediction failed the check and a heading within its error (local_sigmas) passed it:
  /// the step was measured at that heading (a turn's heading error, or the heading part of a
  /// slip; the wide search may still have run).
  bool heading_passed = false;
};

/// When the wide search (steps 2-4) runs after the check fails.
enum class WideSearch {
  kAlways,
  /// Only when a sweep of the heading alone over +-max_slip_deg (steps of 2 x match_px, which
  /// the scoring window covers) finds a heading that would pass the check (trigger_fraction of
  /// the references in view) and explains min_matches and win_ratio x the prediction's
  /// matches. For references that often fail the check without the pose being wrong
  /// (landmarks predicted in view but hidden behind nearer surfaces): an error large enough to
  /// matter moves every pixel sideways, which a heading change largely undoes, and the sweep
  /// costs a few dozen scorings where the wide search costs thousands of votes. On office
  /// (no pose error) the earlier map's references gave sweeps of at most 28 of 120; after
  /// office_loops' missed slip 55-101. Its rivals count all their matches, shared with the
  /// winner or not: matches to references most of which are hidden may be chance matches of
  /// both (counting only unshared ones re-anchored corridor_posters four times, wrongly).
  kAfterHeadingSweep,
};

/// The search's scratch buffers (the hypothesis grid, candidates, votes); one per pipeline, not
/// thread-safe. Results are a pure function of the inputs.
class PoseSearch {
 public:
  /// `prediction_cov`: the prediction's planar covariance (x, y, yaw; m^2, rad^2).
  /// `reference_w`: map positions of the reference landmarks [m]; `hyps`: the frame's salient
  /// points and disparity hypotheses. Returns the prediction unchanged unless accepted.
  PoseSearchResult run(const StereoRig& rig,
                       const Eigen::Isometry3d& T_w_b_predicted,
                       const Eigen::Matrix3d& prediction_cov,
                       const std::vector<Eigen::Vector3d>& reference_w,
                       const StereoHypotheses& hyps,
                       const PoseSearchOptions& options,
                       WideSearch wide = WideSearch::kAlways);

 private:
  struct Candidate {
    Eigen::Vector3d q_b;  // the hypothesis' stereo point in the true body frame [m]
    uint32_t point;
  };
  void buildGrid(const StereoRig& rig, const StereoHypotheses& hyps);
  /// Calls fn(point index) for every salient point in the grid cells that overlap the pixel
  /// box [u0, u1] x [v0, v1], cell by cell in row order; callers test the exact bounds.
  template <typename Fn>
  void forEachPointInCells(double u0, double u1, double v0, double v1, Fn&& fn) const;
  /// One-to-one matches of the reference landmarks at pose T_w_b: per landmark, in input order,
  /// the nearest untaken salient point within match_px whose hypotheses hold one within
  /// match_disparity_px. Returns the count; in_view and matches (reference index, point) are
  /// optional.
  int scoreMatches(const StereoRig& rig,
                   const Eigen::Isometry3d& T_w_b,
                   const std::vector<Eigen::Vector3d>& reference_w,
                   const StereoHypotheses& hyps,
                   const PoseSearchOptions& options,
                   int* in_view,
                   std::vector<std::pair<int, uint32_t>>* matches);

  /// Expected chance matches at T_w_b: per reference landmark in view, the chance that a
  /// salient point with a disparity within match_disparity_px falls into its match window, from
  /// the density of such points in the ring round it.
  double chanceMatches(const StereoRig& rig,
                       const Eigen::Isometry3d& T_w_b,
                       const std::vector<Eigen::Vector3d>& reference_w,
                       const StereoHypotheses& hyps,
                       const PoseSearchOptions& options) const;

  /// Robust planar fit of the correction to `matches_` (see PoseSearchResult::step), from
  /// `start`; false when too few inliers.
  bool fitStep(const StereoRig& rig,
               const Eigen::Isometry3d& T_w_b_predicted,
               const std::vector<Eigen::Vector3d>& reference_w,
               const StereoHypotheses& hyps,
               const Pose2& start,
               PoseSearchResult* result) const;

  static constexpr int kCellPx = 8;
  int cols_ = 0, rows_ = 0;
  std::vector<uint32_t> cell_start_;  // cols_ * rows_ + 1
  std::vector<uint32_t> cell_points_;
  std::vector<uint32_t> claimed_;  // per point: stamp of the scoring that took it
  uint32_t stamp_ = 0;
  std::vector<Candidate> candidates_;
  std::vector<uint32_t> candidate_start_;  // per reference landmark used
  std::vector<uint32_t> votes_;            // the vote histogram
  std::vector<uint32_t> point_votes_;      // single-landmark votes, one per landmark and bin
  std::vector<uint32_t> point_voter_;      // per bin: 1 + the last landmark that voted there
  std::vector<std::pair<int, uint32_t>> matches_;
  std::vector<std::pair<int, uint32_t>> tried_matches_;  // the scored bins' matches
  static constexpr uint32_t kNoPoint = 0xFFFFFFFFU;
  std::vector<uint32_t> winner_point_;  // per reference landmark: its point at the winner
};

/// The pose the landmark database should predict and gate the frame's landmarks with: the
/// search's (the prediction, or the searched pose when accepted), except when the prediction
/// failed the check, a heading within its error passed it and the wide search did not run
/// (with options.associate_at_step): then the prediction corrected by the step the reference
/// landmarks measured there. In a turn one odometry step's heading error within the
/// prediction's covariance (1.1 degrees against a sigma of 0.7, office_loops seed 2, frame 721)
/// moves every gate ~9 px, the gates take neighbouring corners (17 inliers of 174) and the
/// update moved the pose 1.9 cm sideways instead of turning it. Only the association moves:
/// the update's prior stays the prediction (the step as the prior as well would count the
/// references twice). Where the wide search ran and was refused (ambiguous), the heading may
/// explain part of a slip only, and the prediction is kept.
Eigen::Isometry3d associationPose(const PoseSearchResult& result,
                                  const Eigen::Isometry3d& T_w_b_predicted,
                                  const PoseSearchOptions& options);

/// Whether a searched pose with `best` matches stands out from the best distinct pose's
/// `rival` matches: rival below ambiguity_ratio x best, and best - rival at least
/// ambiguity_sigmas x sqrt(best + rival) (PoseSearchOptions).
bool winnerStandsOut(int best, int rival, const PoseSearchOptions& options);

/// Planar rigid fit p_i = R(yaw) q_i + t (x, y only) by least squares; (t_x, t_y, yaw).
Pose2 fitPlanar(const std::vector<Eigen::Vector2d>& q, const std::vector<Eigen::Vector2d>& p);

}  // namespace twocam::localization
