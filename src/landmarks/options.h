#pragma once
/// Options of the landmark database, one struct per part, as in the config file's groups
/// (landmarks.tracker, landmarks.tracker.odometry_noise, landmarks.refine, landmarks.consistency,
/// landmarks.seen_count, landmarks.culling, landmarks.inlier_ratio): the tracker (prediction,
/// gating, association, life cycle and caps) that every policy shares, the refinement at
/// confirmation, and each confirmation policy's own rules. The model and the reasons for every
/// default are written down in docs/landmarks.md.

#include <string>
#include <vector>

#include "common/odometry_noise.h"
#include "common/status.h"

namespace twocam::landmarks {

/// How a candidate earns its confirmation. `kConsistency` is TwoCam's own; the others are the
/// baselines of the landmark-confidence experiments, run on the same frontend output and the same
/// prediction/association machinery so that only the rule differs.
enum class Policy {
  kConsistency,  ///< log-odds existence from hits/misses under odometry motion, rival-normalised
  kWtaLrc,       ///< best SAD with a left-right check, accepted at once
  kSeenCount,    ///< MRPT CLandmarksMap rule: seen at least twice within 4 s
  kCulling,      ///< ORB-SLAM map point culling: found/visible >= 0.25 with >= 3 observations
  kInlierRatio,  ///< SVO depth seed: Gaussian inverse depth with a Beta inlier ratio
};

/// Names used on the command line: consistency, wta-lrc, seen-count, culling, inlier-ratio.
const char* policyName(Policy policy);
Status parsePolicy(const std::string& name, Policy* policy);
const std::vector<Policy>& allPolicies();

/// The policy-agnostic tracker: noise model, gates, visibility, life cycle and caps.
struct TrackerOptions {
  /// The odometry noise the gates and the refinement assume (common/odometry_noise.h).
  OdometryNoise odometry_noise;
  /// Corner localisation noise [px] (Harris at integer pixels: uniform +-0.5 has sigma 0.29;
  /// 0.5 also covers rig vibration).
  double pixel_sigma_px = 0.5;
  /// Disparity noise [px] of a sub-pixel SAD match.
  double disparity_sigma_px = 0.5;
  /// Gate on the squared Mahalanobis distance in (u, v, d): 11.34 is the 99 % quantile of
  /// chi-square with 3 degrees of freedom.
  double gate_chi2 = 11.34;
  /// Predictions closer than this to the image edge count as not visible [px] (the frontend finds
  /// no corners in its border).
  double visibility_border_px = 8.0;
  /// Landmarks nearer than this along the optical axis are not predicted [m].
  double min_depth_m = 0.2;
  /// Disparity search range of the frontend [px]; a prediction outside it cannot be observed.
  /// Not a config key: pipeline::clampToRig sets it from frontend.sad.
  double min_disparity_px = 0.0;
  /// Upper end of that range [px] (set by clampToRig too).
  double max_disparity_px = 63.0;
  /// A candidate predicted visible but not associated for this many consecutive frames is
  /// dropped (all policies) [-].
  int max_consecutive_misses = 8;
  /// A confirmed landmark predicted visible but not seen for this many consecutive frames is
  /// retired [-]: odometry drift has moved it away from where its corner now appears (which is
  /// then confirmed afresh), or it was wrong. 45 frames = 3 s at 15 Hz. Without this a robot
  /// that revisits a place grows its map on every visit.
  int max_confirmed_misses = 45;
  /// A candidate not predicted visible for this many frames is dropped; confirmed landmarks are
  /// kept when they leave the view [-].
  int max_frames_out_of_view = 5;
  /// Hard cap on confirmed landmarks; the least recently seen are dropped first [-]. With odometry
  /// drift a robot that keeps revisiting places re-confirms their corners in the drifted frame,
  /// so only a cap bounds memory on endless runs (about 1.2 kB per landmark: 60 MB here).
  int max_confirmed = 50000;
  /// Hard cap on live candidates; the least confident are dropped first [-].
  int max_candidates = 20000;
  /// Observations kept per landmark for refinement: the anchor plus the most recent ones [-].
  int max_observations = 24;
  /// Seed candidates from hypotheses whose matching window was shifted off the corner
  /// (DisparityHypothesis::window_shift_px != 0): the frontend matched only one side of the
  /// corner, i.e. the corner lies on a depth edge, where its 3-D point is ill-defined (it
  /// slides along the occluding contour as the robot moves) and METRICS.md leaves it without
  /// ground truth.
  bool seed_depth_edges = false;
  /// Fusion (docs/landmarks.md#fusion): a confirmed landmark predicted within this many pixels
  /// (in u and in v) of a corner is that corner's landmark, met again: at seeding it takes the
  /// corner (even when its gate held other corners), and a candidate about to be confirmed
  /// there is dropped instead of confirmed a second time [px]. Only landmarks whose prediction
  /// error makes their own corner likelier than another within the radius take part. Below 2:
  /// Harris' 3x3 non-maximum suppression keeps two corners of one frame 2 px apart. 0 (the
  /// default) turns fusion off: with it on (1.5) duplicates halve, but the slip search, whose
  /// thresholds were set with duplicates in the reference, detects fewer slips
  /// (docs/experiments/2026-12-03-landmark-fusion.md).
  double fuse_radius_px = 0.0;
  double fuse_disparity_px = 1.5;

  /// Ranges as in the config's comments; ints bounded so that counters and capacities cannot
  /// overflow. Messages start with "landmarks.tracker.".
  [[nodiscard]] Status validate() const;
};

/// The multi-view refinement of a landmark's depth at its confirmation (landmarks/refine.h).
struct RefinementOptions {
  /// Refine a landmark's depth with Ceres over its observations when it is confirmed. Confirmed
  /// landmarks are not re-refined later: their associations are tracked without the anchor check,
  /// and re-refining over them cost 7 points of precision on the office world (docs/landmarks.md).
  bool enabled = true;
  /// Huber loss scale of the refinement residuals, in units of their sigma [-].
  double huber = 1.0;

  [[nodiscard]] Status validate() const;
};

/// The `consistency` policy: log-odds existence from hits and misses under odometry motion,
/// normalised over the rival hypotheses of a corner (docs/landmarks.md).
struct ConsistencyOptions {
  /// Prior probability that a salient point's hypotheses contain the real match [-]; it is split
  /// among the rivals (LR-consistent ones count double).
  double prior_real = 0.5;
  /// Probability that a real, visible landmark is re-detected and matched in a frame [-]
  /// (Harris repeatability between consecutive frames is about 0.7-0.9).
  double detection_prob = 0.75;
  /// Evidence of one hit is log(detection_prob / p_false_hit), where p_false_hit is the chance
  /// that some hypothesis falls into the gate by accident (hypothesis density x gate volume); it
  /// is capped here [nats] because hits of one landmark are not independent (a spurious match on a
  /// periodic texture reappears nearby for small motions).
  double max_hit_evidence = 1.5;
  /// Evidence of a re-observation that agrees with the anchor before the motion could expose a
  /// wrong depth [nats]: it shows the corner is stable (not a one-frame noise response) but says
  /// nothing about which rival is real, so it is small. Rivals gain it alike and normalisation
  /// keeps them level; a lone hypothesis climbs on it.
  double stability_evidence = 0.7;
  /// Evidence is counted only after the robot has moved this far since the landmark's last
  /// counted evidence [m]: without motion a spurious match reappears just like a real one.
  /// 0.01 (1 cm, until 2026-12-02 0.04): at the worlds' 0.4 m/s a frame covers 2.7 cm at 15 Hz
  /// and 5 cm at 8 Hz, so every frame that moves counts, while standing still (or turning on
  /// the spot, which gives no parallax) still counts nothing. 0.04 counted only every other frame
  /// at 15 Hz; 0.01 gave 8-92 % more correct landmarks in all 12 logs at strict precision within
  /// -0.7 / +1.0 points (docs/landmarks.md, "Evidence step").
  double evidence_step_m = 0.01;
  /// A candidate's re-observation is checked against its anchor: the anchor's triangulation,
  /// moved by the odometry since the anchor frame, must predict the observed column, row and
  /// disparity within this squared Mahalanobis distance. 9.21 is the 97.3 % quantile of
  /// chi-square with 3 degrees of freedom (the 99 % one with 2, its value when only rows and
  /// disparities were compared); measured on office and repetitive it gave higher precision than
  /// 11.34 (99 %, 3 dof) and 7.81 (95 %), see docs/landmarks.md.
  double anchor_gate_chi2 = 9.21;
  /// Compare the column in the anchor check too, with the odometry heading error in its sigma
  /// (fx sigma_yaw, so turns make it uninformative while straight driving keeps it sharp). Near
  /// the horizon and under forward motion a periodic-texture alias keeps its row and gains less
  /// than a pixel of disparity, but its column moves like the real point's, not like its own
  /// depth predicts: on the repetitive world the column took wrongly confirmed landmarks from 13
  /// to 7 (docs/landmarks.md). false restores the row/disparity check.
  bool anchor_check_columns = true;
  /// Evidence of a re-observation that contradicts the anchor [nats]: a real landmark does this
  /// only on an outlier association (about 1 in 50), a spurious one as soon as the motion exposes
  /// its wrong depth (about 1 in 2): log(0.02 / 0.5) = -3.2.
  double contradiction_evidence = -3.2;
  /// Confirmation: existence probability at least this [-] ... 0.9 since the row-support rule
  /// (below) took over most of what a high threshold guarded against: with it, 0.9 gave more
  /// correct landmarks than 0.97 in all 12 logs (office x1 +15 %) at higher strict precision in
  /// 11 of them; 0.85 and 0.8 gave still more but let periodic-texture aliases through on the
  /// repetitive world (judged-wrong 6 at 0.9, 18 at 0.85, 35 at 0.8; docs/landmarks.md).
  double confirm_prob = 0.9;
  /// ... and, for a candidate that had rivals when it was created, verification: its
  /// re-observations must tell it from a periodic-texture phantom. Were the real point on the
  /// anchor ray at disparity d +- max(verify_min_offset_px, verify_relative_offset * d), the
  /// candidate (a phantom of it, its disparity a fixed multiple of the real one) would be seen
  /// where the real point is; each consistent re-observation gives the log-likelihood ratio of
  /// the candidate against each phantom (AnchorCheck::phantom_llr), and the candidate is
  /// verified once their sums reach verify_llr for both [nats]: 5, a likelihood ratio of about
  /// 150. Rival minima of a SAD curve lie at least 2 px apart (the frontend's minimum
  /// separation), hence 2 px; 0.2 d (a 20 % depth change) keeps near points, where 2 px is a
  /// tiny depth change, confirmable within a metre of travel. Until 2026-12-02 one observation
  /// had to come after motion that put both phantoms verify_chi2 away (16, then 9.21 for one
  /// day): that asked for so much motion that on the office world 17 297 true candidates with
  /// rivals left the view unverified; summing the evidence of every observation gave 5-20 %
  /// more correct landmarks than one frame at 9.21 on the four worlds (office +15 %,
  /// repetitive +20 %), at strict precision within -0.4 / +0.2 points (docs/landmarks.md,
  /// "Verification").
  double verify_min_offset_px = 2.0;
  /// Relative part of the phantom offset (see verify_min_offset_px) [-].
  double verify_relative_offset = 0.2;
  /// Summed log-likelihood ratio against both phantoms needed for verification [nats].
  double verify_llr = 5.0;
  /// Verification against the corner's own rivals: when the frontend says a corner's hypothesis
  /// list is complete (SalientPoint::complete: every minimum within its cost ratio is listed,
  /// none cut off by the list's size or the image border, and no dearer minimum continues the
  /// list's period, SalientSadOptions::complete_cost_ratio), the real point, if there is one, is
  /// among the hypotheses, so the phantoms a candidate must be told from sit at its rivals'
  /// disparities (the nearest one below and above its own; a side without a rival needs no
  /// evidence), as a lone hypothesis needs none at all. Incomplete lists keep the offsets above.
  bool verify_own_rivals = true;
  /// Hypotheses of one corner within this many px of each other are the same answer
  /// (METRICS.md's truth tolerance is 1 px) [px], >= 0. The frontend's cost curves (window
  /// alignments) often find one disparity as integer minima 1 px apart whose sub-pixel fits
  /// lie 0.0-0.6 px apart; no motion tells them apart. So (consistency policy) only the
  /// cheapest of them is seeded, and a candidate's own-rival phantoms pass over them for the
  /// next rival on that side. Before (office x1, 2026-12-02) 3509 true candidates with
  /// probability >= 0.9 left the view unverified for such a twin, against 14 wrong ones, and
  /// twins split the belief of one point. 0 seeds and verifies against every hypothesis. The
  /// baselines seed every hypothesis whatever this says (their published rules).
  double same_answer_px = 1.0;
  /// A consistent hit counts fully (hit evidence, up to max_hit_evidence) only after motion that
  /// would predict both phantoms at least this far away in one frame (squared Mahalanobis
  /// distance [-]); before that it counts stability_evidence. 9.21, the anchor gate
  /// (anchor_gate_chi2): a phantom is then predicted where the anchor check calls it a
  /// contradiction (16 until 2026-12-02, when this also decided verification).
  double verify_chi2 = 9.21;
  /// Observations (anchor included) needed to confirm [-].
  int min_observations = 4;
  /// ... and a minimum parallax [deg], >= 0 and < 90: the angle at the candidate's anchor point
  /// between the anchor's left-camera centre and that of at least one later consistent
  /// observation. Below about a pixel of bearing change (0.11 deg at 500 px focal length, twice
  /// pixel_sigma_px) the viewpoints are one, and a re-observation tests the corner's stability
  /// but hardly its depth. A stereo rig has depth from every frame, so this only keeps
  /// confirmations from a single viewpoint out (a point straight ahead of a robot driving at
  /// it); 0.1 was chosen on the 4 worlds (docs/landmarks.md, "Minimum parallax"). Consistency
  /// policy only.
  double min_parallax_deg = 0.1;
  /// Candidates whose probability falls below this are pruned [-].
  double prune_prob = 0.02;
  /// consistency policy, row support: an observation has it when its hypothesis'
  /// DisparityHypothesis::row_span_px (the spread of the disparities matched one row up, on the
  /// corner's row and one row down) is at most max(max_row_span_px, max_row_span_relative * d)
  /// [px], [-]; a candidate is confirmed only when at most max_row_unsupported_fraction of its
  /// observations (anchor included) lacked it [-]. A wrong match (a periodic-texture alias, a
  /// window straddling a depth edge) is seldom matched at the same disparity on the neighbouring
  /// rows in every frame; nor is a corner on a depth edge across the rows, whose depth
  /// METRICS.md leaves undefined (its 3x3 neighbourhood spans more than 5 % in depth). Hence
  /// 5 % and 0.5 px for the sub-pixel noise of far points. 0: every observation must have it;
  /// a real point lacks it in about 2 % of frames, and with confirm_prob 0.9 it is confirmed
  /// after few observations. Measured on the four worlds against 0.05, 0.1 and 0.25, against
  /// refusing to seed unsupported hypotheses and against negative evidence per failure:
  /// docs/landmarks.md, "Row support". Hypotheses whose frontend did not measure it
  /// (row_span_px = 0) always have it; 1 turns the rule off.
  double max_row_span_px = 0.5;
  /// Relative part of that bound (see max_row_span_px) [-].
  double max_row_span_relative = 0.05;
  /// Largest fraction of observations without row support for a confirmation (see max_row_span_px)
  /// [-].
  double max_row_unsupported_fraction = 0.0;
  /// consistency policy: a confirmed landmark whose association gate holds more than one
  /// corner is not associated in that frame (it counts as unseen). After a long absence its gate,
  /// widened by odometry drift, holds several corners; taking the nearest lets the landmark live
  /// on a neighbour while its own corner is confirmed again (docs/landmarks.md, "Duplicates").
  bool unambiguous_confirmed_hits = true;
  /// consistency policy: a candidate predicted visible but not associated with any of the
  /// frame's hypotheses (its corner was not detected, or another landmark took it) is measured
  /// again at its predicted pixel with the frontend's matcher (LandmarkDatabase::update's
  /// probe). When that gives exactly one answer, inside the candidate's gate and with row
  /// support, the frame counts neither as a hit nor as a miss: the point is there at the
  /// predicted depth, but a measurement placed at the prediction cannot test its column, so it
  /// adds no evidence and no observation. Harris corners flicker (a true candidate of the
  /// garden world found no corner in its gate in a third of its frames), and without this each
  /// flicker was a miss that pruned real points. Needs the images: runs without a probe
  /// (replayed hypotheses, the landmarks benchmark) behave as false. Its time counts in the
  /// landmark stage. docs/landmarks.md, "Probing unseen candidates".
  bool probe_unseen = true;

  [[nodiscard]] Status validate() const;
};

/// The `seen-count` baseline (MRPT CLandmarksMap): seen often enough within a time window.
struct SeenCountOptions {
  /// seen-count: observations needed and the window they must fall into [s] (MRPT CLandmarksMap).
  int min_observations = 2;
  /// Window, from the candidate's creation, the observations must fall into [s].
  double window_s = 4.0;

  [[nodiscard]] Status validate() const;
};

/// The `culling` baseline (ORB-SLAM MapPointCulling).
struct CullingOptions {
  /// culling: minimum found/visible ratio and observations (ORB-SLAM MapPointCulling), and the
  /// number of frames after creation at which the rule is applied.
  double min_found_ratio = 0.25;
  /// Observations needed (anchor included) [-].
  int min_observations = 3;
  /// Frames after creation at which the rule is applied [-].
  int decision_frames = 3;

  [[nodiscard]] Status validate() const;
};

/// The `inlier-ratio` baseline (SVO depth seed).
struct InlierRatioOptions {
  /// inlier-ratio: SVO seed convergence when the inverse-depth sigma falls below this fraction of
  /// the seed's inverse-depth range, and the inlier ratio a / (a + b) at least the threshold.
  double converged_sigma_fraction = 1.0 / 200.0;
  /// Inlier ratio a / (a + b) needed to confirm a converged seed [-].
  double min_inlier_ratio = 0.6;
  /// SVO seeds whose inlier ratio falls below this are dropped.
  double prune_inlier_ratio = 0.1;

  [[nodiscard]] Status validate() const;
};

struct LandmarkOptions {
  /// Which confirmation rule decides; the other policies' groups are kept but not read.
  Policy policy = Policy::kConsistency;
  TrackerOptions tracker;
  RefinementOptions refine;
  ConsistencyOptions consistency;
  SeenCountOptions seen_count;
  CullingOptions culling;
  InlierRatioOptions inlier_ratio;

  /// Validates every group (all of them, whatever the policy, so that a config stays valid
  /// when only the policy is switched); messages name the key, e.g.
  /// "landmarks.consistency.confirm_prob = 1.5; must be in (0, 1)".
  [[nodiscard]] Status validate() const;
};

}  // namespace twocam::landmarks
