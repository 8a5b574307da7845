#pragma once
/// The configuration's key tree: one visit function per option struct, shared by the reader, the
/// writer and the list of allowed keys of pipeline/config.cpp (internal to the pipeline library).

#include <cstddef>
#include <type_traits>
#include <utility>

#include "pipeline/config.h"

namespace twocam::pipeline::config_schema {

// ---- every field mapped ----------------------------------------------------------------------
// The option structs are aggregates, so their field count is the largest N for which T{x1..xN}
// compiles. The static_asserts below fail when a field is added or removed without updating the
// visit functions: update the visit function, the count here and in tests/pipeline/config_test.cpp,
// docs/config.md and configs/default.yaml (TWOCAM_REGENERATE_CONFIGS=1 ctest -R
// PipelineConfigDefaultFile).

struct AnyField {
  template <typename T>
  operator T() const;  // NOLINT(google-explicit-constructor): only used in unevaluated context
};
template <typename T, typename Seq, typename = void>
struct BraceInitializable : std::false_type {};
template <typename T, size_t... I>
struct BraceInitializable<T,
                          std::index_sequence<I...>,
                          std::void_t<decltype(T{(void(I), AnyField{})...})>> : std::true_type {};
template <typename T, size_t N = 0>
constexpr size_t fieldCount() {
  if constexpr (BraceInitializable<T, std::make_index_sequence<N + 1>>::value) {
    return fieldCount<T, N + 1>();
  } else {
    return N;
  }
}

static_assert(fieldCount<frontend::HarrisOptions>() == 13,
              "HarrisOptions gained or lost a field: map it in visitHarris (see above)");
static_assert(fieldCount<frontend::SalientSadOptions>() == 17,
              "SalientSadOptions gained or lost a field: map it in visitSad (see above)");
static_assert(fieldCount<frontend::FrontendOptions>() == 4,
              "FrontendOptions gained or lost a field: map it in visitFrontend (see above)");
static_assert(fieldCount<landmarks::LandmarkOptions>() == 7,
              "LandmarkOptions gained or lost a field: map it in visitLandmarks (see above)");
// 15 fields, two of which (min/max_disparity_px) clampToRig sets from frontend.sad.
static_assert(fieldCount<landmarks::TrackerOptions>() == 17,
              "TrackerOptions gained or lost a field: map it in visitTracker (see above)");
static_assert(fieldCount<OdometryNoise>() == 5,
              "OdometryNoise gained or lost a field: map it in visitOdometryNoise (see above)");
static_assert(fieldCount<landmarks::RefinementOptions>() == 2,
              "RefinementOptions gained or lost a field: map it in visitRefine (see above)");
static_assert(fieldCount<landmarks::ConsistencyOptions>() == 23,
              "ConsistencyOptions gained or lost a field: map it in visitConsistency (see above)");
static_assert(fieldCount<landmarks::SeenCountOptions>() == 2,
              "SeenCountOptions gained or lost a field: map it in visitSeenCount (see above)");
static_assert(fieldCount<landmarks::CullingOptions>() == 3,
              "CullingOptions gained or lost a field: map it in visitCulling (see above)");
static_assert(fieldCount<landmarks::InlierRatioOptions>() == 3,
              "InlierRatioOptions gained or lost a field: map it in visitInlierRatio (see above)");
static_assert(fieldCount<mapping::MappingOptions>() == 8,
              "MappingOptions gained or lost a field: map it in visitMapping (see above)");
static_assert(
    fieldCount<localization::LocalizationOptions>() == 6,
    "LocalizationOptions gained or lost a field: map it in visitLocalization (see above)");
static_assert(fieldCount<localization::PoseSearchOptions>() == 21,
              "PoseSearchOptions gained or lost a field: map it in visitLocalization (see above)");
static_assert(fieldCount<localization::PoseUpdateOptions>() == 9,
              "PoseUpdateOptions gained or lost a field: map it in visitLocalization (see above)");
static_assert(fieldCount<PipelineConfig>() == 5,
              "PipelineConfig gained or lost a field: map it in visitConfig (see above)");

// ---- the layout: one visit function per struct ------------------------------------------------
// A visitor V provides
//   v(key, field, comment)               for a leaf (T& when reading, const T& when writing),
//   v.section(key, comment, fn)          for a nested map; fn(V&) visits its keys.
// Reading, writing and the list of allowed keys all come from these functions, so they cannot
// disagree. Comments give the meaning, unit [in brackets] and constraint, from the headers.

/// A leaf whose YAML key is the field's name, by construction.
#define TWOCAM_CONFIG_KEY(field, comment) v(#field, o.field, comment)

template <typename O, typename V>
void visitHarris(O& o, V& v) {
  TWOCAM_CONFIG_KEY(k, "Harris sensitivity in det(M) - k trace(M)^2 [-], in (0, 0.25)");
  TWOCAM_CONFIG_KEY(border_px, "no corner closer than this to an image edge [px], in [4, 32768]");
  TWOCAM_CONFIG_KEY(target_count,
                    "corners per frame the adaptive threshold steers to [-], in [1, 2^24]");
  TWOCAM_CONFIG_KEY(initial_threshold, "threshold on R for the first frame [grey level^4]");
  TWOCAM_CONFIG_KEY(threshold_adapt_rate,
                    "weight of the latest frame in the threshold update [-], in [0, 1]");
  TWOCAM_CONFIG_KEY(threshold_min, "lower clamp of the adaptive threshold [grey level^4]");
  TWOCAM_CONFIG_KEY(threshold_max, "upper clamp of the adaptive threshold [grey level^4]");
  TWOCAM_CONFIG_KEY(max_corners, "hard cap on corners per frame, strongest kept [-], in [1, 2^24]");
  TWOCAM_CONFIG_KEY(bucketing, "keep at most max_per_cell corners per grid cell [bool]");
  TWOCAM_CONFIG_KEY(grid_cols, "bucketing grid columns [-], in [1, 4096]");
  TWOCAM_CONFIG_KEY(grid_rows, "bucketing grid rows [-], in [1, 4096]");
  TWOCAM_CONFIG_KEY(max_per_cell, "corners kept per bucketing cell [-], in [1, 2^24]");
  v.replaced("use_avx2", "frontend.simd");  // HarrisOptions::simd is set from frontend.simd
}

template <typename O, typename V>
void visitSad(O& o, V& v) {
  TWOCAM_CONFIG_KEY(window_width_px, "width W of the 1xW matching window [px], odd, in [3, 63]");
  TWOCAM_CONFIG_KEY(min_disparity_px, "smallest disparity searched [px], in [0, 32768]");
  TWOCAM_CONFIG_KEY(max_disparity_px,
                    "largest disparity searched [px], <= 32768, max - min + 1 <= 256");
  TWOCAM_CONFIG_KEY(row_tolerance_px, "right rows v-m..v+m are searched too [px], in [0, 8]");
  TWOCAM_CONFIG_KEY(max_hypotheses, "rival hypotheses kept per point [-], in [1, 255]");
  TWOCAM_CONFIG_KEY(cost_ratio, "keep minima costing <= cost_ratio * best cost [-], >= 1");
  TWOCAM_CONFIG_KEY(complete_cost_ratio,
                    "an unlisted minimum within this x best that continues the list's period makes "
                    "it incomplete [-], >= cost_ratio");
  TWOCAM_CONFIG_KEY(min_separation_px, "distinct minima at least this far apart [px], in [1, 256]");
  TWOCAM_CONFIG_KEY(lr_tolerance_px, "right-to-left check tolerance [px], in [0, 256]");
  TWOCAM_CONFIG_KEY(lr_check, "run the right-to-left check [bool]");
  TWOCAM_CONFIG_KEY(max_cost_per_px,
                    "drop hypotheses costing more than this * W [grey levels/px], 255 = off");
  TWOCAM_CONFIG_KEY(shiftable_windows,
                    "also match windows ending and starting at the corner [bool]");
  TWOCAM_CONFIG_KEY(zero_mean, "zero-mean SAD, robust to a brightness offset [bool]");
  TWOCAM_CONFIG_KEY(
      birchfield_tomasi,
      "sampling-insensitive cost: distance to the right pixel's half-pixel interval [bool]");
  v.replaced("kernel", "frontend.simd");  // SalientSadOptions::simd is set from frontend.simd
  TWOCAM_CONFIG_KEY(row_support, "match each hypothesis on the rows above and below too [bool]");
  TWOCAM_CONFIG_KEY(row_support_radius_px,
                    "row-support search radius around the disparity [px], in [1, 16]");
}

template <typename O, typename V>
void visitFrontend(O& o, V& v) {
  v.section(
      "harris", "Harris corners (frontend/harris.h)", [&](V& s) { visitHarris(o.harris, s); });
  v.section("sad", "salient 1-D SAD matching (frontend/salient_sad.h)", [&](V& s) {
    visitSad(o.sad, s);
  });
  TWOCAM_CONFIG_KEY(source, "where hypotheses come from: sad | pairing | support | ncc | maxtree");
  TWOCAM_CONFIG_KEY(simd,
                    "SIMD build of Harris and the SAD kernels, identical results: "
                    "auto | scalar | sse2 | avx2");
}

template <typename O, typename V>
void visitOdometryNoise(O& o, V& v) {
  TWOCAM_CONFIG_KEY(trans_sigma_per_sqrt_m, "random translation error [m/sqrt(m)], in [0, 1]");
  TWOCAM_CONFIG_KEY(trans_scale_sigma, "systematic relative distance error [-], in [0, 1]");
  TWOCAM_CONFIG_KEY(rot_sigma_per_sqrt_rad, "random heading error [rad/sqrt(rad)], in [0, 1]");
  TWOCAM_CONFIG_KEY(rot_scale_sigma, "systematic relative heading error [-], in [0, 1]");
  TWOCAM_CONFIG_KEY(rot_sigma_per_m, "heading error per metre driven [rad/m], in [0, 1]");
}

template <typename O, typename V>
void visitTracker(O& o, V& v) {
  TWOCAM_CONFIG_KEY(pixel_sigma_px, "corner localisation noise [px], in (0, 100]");
  TWOCAM_CONFIG_KEY(disparity_sigma_px, "disparity noise of a sub-pixel match [px], in (0, 100]");
  TWOCAM_CONFIG_KEY(gate_chi2,
                    "association gate on squared Mahalanobis distance in (u, v, d) [-], in (0, "
                    "1000]");
  TWOCAM_CONFIG_KEY(visibility_border_px,
                    "predictions nearer the edge are not visible [px], in [0, 10000]");
  TWOCAM_CONFIG_KEY(min_depth_m, "nearer landmarks are not predicted [m], in (0, 1000]");
  TWOCAM_CONFIG_KEY(max_consecutive_misses,
                    "candidate dropped after this many misses [frames], in [0, 1000000]");
  TWOCAM_CONFIG_KEY(max_confirmed_misses,
                    "confirmed landmark retired after this many misses [frames], in [1, 1000000]");
  TWOCAM_CONFIG_KEY(max_frames_out_of_view,
                    "candidate dropped after this long out of view [frames], in [0, 1000000]");
  TWOCAM_CONFIG_KEY(max_confirmed,
                    "cap on confirmed landmarks, least recently seen dropped [-], in [1, 1e7]");
  TWOCAM_CONFIG_KEY(max_candidates,
                    "cap on live candidates, least confident dropped [-], in [1, 1e7]");
  TWOCAM_CONFIG_KEY(max_observations,
                    "observations kept per landmark for refinement [-], in [2, 1000]");
  TWOCAM_CONFIG_KEY(seed_depth_edges,
                    "seed candidates from shifted-window (depth edge) matches [bool]");
  TWOCAM_CONFIG_KEY(fuse_radius_px,
                    "fusion: a confirmed landmark predicted this near a corner is its own [px], "
                    "in [0, 2); 0 = off");
  TWOCAM_CONFIG_KEY(fuse_disparity_px, "disparity tolerance of that fusion test [px], in [0, 100]");
  v.section("odometry_noise",
            "odometry noise model of the gates (common/odometry_noise.h)",
            [&](V& s) { visitOdometryNoise(o.odometry_noise, s); });
}

template <typename O, typename V>
void visitRefine(O& o, V& v) {
  TWOCAM_CONFIG_KEY(enabled, "refine a landmark's depth with Ceres when confirmed [bool]");
  TWOCAM_CONFIG_KEY(huber, "Huber loss scale of the refinement [sigma], in (0, 1000]");
}

template <typename O, typename V>
void visitConsistency(O& o, V& v) {
  TWOCAM_CONFIG_KEY(prior_real,
                    "prior that a point's hypotheses hold the real match [-], in (0, 1)");
  TWOCAM_CONFIG_KEY(detection_prob,
                    "re-detection probability of a visible landmark [-], in (0, 1)");
  TWOCAM_CONFIG_KEY(max_hit_evidence, "cap on the evidence of one hit [nats], in (0, 100]");
  TWOCAM_CONFIG_KEY(stability_evidence,
                    "evidence of an anchor-consistent re-observation [nats], in [0, 100]");
  TWOCAM_CONFIG_KEY(evidence_step_m, "motion needed between counted evidence [m], in [0, 1000]");
  TWOCAM_CONFIG_KEY(anchor_gate_chi2,
                    "anchor check gate on squared Mahalanobis distance (u, v, d) [-], in (0, "
                    "1000]");
  TWOCAM_CONFIG_KEY(anchor_check_columns, "anchor check compares the column too [bool]");
  TWOCAM_CONFIG_KEY(contradiction_evidence,
                    "evidence of an anchor contradiction [nats], in [-100, 0]");
  TWOCAM_CONFIG_KEY(confirm_prob, "existence probability needed to confirm [-], in (0, 1)");
  TWOCAM_CONFIG_KEY(verify_min_offset_px,
                    "phantom disparity offset, absolute part [px], in [0, 10000]");
  TWOCAM_CONFIG_KEY(verify_relative_offset,
                    "phantom disparity offset, fraction of d [-], in [0, 100]");
  TWOCAM_CONFIG_KEY(verify_llr,
                    "evidence against the phantoms needed to confirm [nats], in [0, 1000]");
  TWOCAM_CONFIG_KEY(verify_own_rivals,
                    "complete hypothesis lists: phantoms at the rivals' disparities [bool]");
  TWOCAM_CONFIG_KEY(same_answer_px,
                    "hypotheses of a corner this near each other are one answer [px], in [0, "
                    "10000]");
  TWOCAM_CONFIG_KEY(verify_chi2, "phantoms this far away make a hit count fully [-], in [0, 1000]");
  TWOCAM_CONFIG_KEY(min_observations, "observations needed to confirm [-], in [1, 1000000]");
  TWOCAM_CONFIG_KEY(min_parallax_deg, "viewpoint change needed to confirm [deg], in [0, 90)");
  TWOCAM_CONFIG_KEY(prune_prob,
                    "candidates below this probability are pruned [-], in [0, confirm_prob)");
  TWOCAM_CONFIG_KEY(max_row_span_px,
                    "an observation has row support when its span <= max(this, relative * d) "
                    "[px], in [0, 10000]");
  TWOCAM_CONFIG_KEY(max_row_span_relative, "relative part of that bound [-], in [0, 100]");
  TWOCAM_CONFIG_KEY(max_row_unsupported_fraction,
                    "confirm only if at most this fraction of observations lacked row support "
                    "[-], in [0, 1]");
  TWOCAM_CONFIG_KEY(unambiguous_confirmed_hits,
                    "a confirmed landmark with several corners in its gate is not associated "
                    "[bool]");
  TWOCAM_CONFIG_KEY(probe_unseen,
                    "re-measure an unassociated candidate at its predicted pixel; one answer in "
                    "its gate is not a miss [bool]");
}

template <typename O, typename V>
void visitSeenCount(O& o, V& v) {
  TWOCAM_CONFIG_KEY(min_observations, "observations needed [-], in [1, 1000000]");
  TWOCAM_CONFIG_KEY(window_s, "window they must fall into [s], in (0, 1000000]");
}

template <typename O, typename V>
void visitCulling(O& o, V& v) {
  TWOCAM_CONFIG_KEY(min_found_ratio, "minimum found/visible [-], in [0, 1]");
  TWOCAM_CONFIG_KEY(min_observations, "minimum observations [-], in [1, 1000000]");
  TWOCAM_CONFIG_KEY(decision_frames, "frames after creation the rule applies [-], in [1, 1000000]");
}

template <typename O, typename V>
void visitInlierRatio(O& o, V& v) {
  TWOCAM_CONFIG_KEY(converged_sigma_fraction, "convergence sigma / range [-], in (0, 1)");
  TWOCAM_CONFIG_KEY(min_inlier_ratio, "ratio needed to confirm [-], in (0, 1)");
  TWOCAM_CONFIG_KEY(prune_inlier_ratio,
                    "seeds below this are dropped [-], in [0, min_inlier_ratio)");
}

/// Keys of the flat landmarks section before the groups (2026-12-02): reading one is an error
/// that names where it went.
struct MovedKey {
  const char* old_key;
  const char* new_key;  // nullptr: removed, see `why`
  const char* why;
};
constexpr MovedKey kMovedLandmarkKeys[] = {
    {"odom_trans_sigma_per_sqrt_m", "tracker.odometry_noise.trans_sigma_per_sqrt_m", nullptr},
    {"odom_trans_scale_sigma", "tracker.odometry_noise.trans_scale_sigma", nullptr},
    {"odom_rot_sigma_per_sqrt_rad", "tracker.odometry_noise.rot_sigma_per_sqrt_rad", nullptr},
    {"odom_rot_scale_sigma", "tracker.odometry_noise.rot_scale_sigma", nullptr},
    {"odom_rot_sigma_per_m", "tracker.odometry_noise.rot_sigma_per_m", nullptr},
    {"pixel_sigma_px", "tracker.pixel_sigma_px", nullptr},
    {"disparity_sigma_px", "tracker.disparity_sigma_px", nullptr},
    {"gate_chi2", "tracker.gate_chi2", nullptr},
    {"visibility_border_px", "tracker.visibility_border_px", nullptr},
    {"min_depth_m", "tracker.min_depth_m", nullptr},
    {"max_consecutive_misses", "tracker.max_consecutive_misses", nullptr},
    {"max_confirmed_misses", "tracker.max_confirmed_misses", nullptr},
    {"max_frames_out_of_view", "tracker.max_frames_out_of_view", nullptr},
    {"max_confirmed", "tracker.max_confirmed", nullptr},
    {"max_candidates", "tracker.max_candidates", nullptr},
    {"max_observations", "tracker.max_observations", nullptr},
    {"seed_depth_edges", "tracker.seed_depth_edges", nullptr},
    {"refine_huber", "refine.huber", nullptr},
    {"prior_real", "consistency.prior_real", nullptr},
    {"detection_prob", "consistency.detection_prob", nullptr},
    {"max_hit_evidence", "consistency.max_hit_evidence", nullptr},
    {"stability_evidence", "consistency.stability_evidence", nullptr},
    {"evidence_step_m", "consistency.evidence_step_m", nullptr},
    {"anchor_gate_chi2", "consistency.anchor_gate_chi2", nullptr},
    {"anchor_check_columns", "consistency.anchor_check_columns", nullptr},
    {"contradiction_evidence", "consistency.contradiction_evidence", nullptr},
    {"confirm_prob", "consistency.confirm_prob", nullptr},
    {"verify_min_offset_px", "consistency.verify_min_offset_px", nullptr},
    {"verify_relative_offset", "consistency.verify_relative_offset", nullptr},
    {"verify_llr", "consistency.verify_llr", nullptr},
    {"verify_own_rivals", "consistency.verify_own_rivals", nullptr},
    {"same_answer_px", "consistency.same_answer_px", nullptr},
    {"verify_chi2", "consistency.verify_chi2", nullptr},
    {"min_observations", "consistency.min_observations", nullptr},
    {"min_parallax_deg", "consistency.min_parallax_deg", nullptr},
    {"prune_prob", "consistency.prune_prob", nullptr},
    {"max_row_span_px", "consistency.max_row_span_px", nullptr},
    {"max_row_span_relative", "consistency.max_row_span_relative", nullptr},
    {"max_row_unsupported_fraction", "consistency.max_row_unsupported_fraction", nullptr},
    {"unambiguous_confirmed_hits", "consistency.unambiguous_confirmed_hits", nullptr},
    {"probe_unseen", "consistency.probe_unseen", nullptr},
    {"seen_count_min", "seen_count.min_observations", nullptr},
    {"seen_count_window_s", "seen_count.window_s", nullptr},
    {"culling_min_found_ratio", "culling.min_found_ratio", nullptr},
    {"culling_min_observations", "culling.min_observations", nullptr},
    {"culling_decision_frames", "culling.decision_frames", nullptr},
    {"svo_converged_sigma_fraction", "inlier_ratio.converged_sigma_fraction", nullptr},
    {"svo_min_inlier_ratio", "inlier_ratio.min_inlier_ratio", nullptr},
    {"svo_prune_inlier_ratio", "inlier_ratio.prune_inlier_ratio", nullptr},
    {"prior_real_lone", nullptr, "no default used it; a lone candidate takes prior_real"},
    {"min_disparity_px", nullptr, "twocam run sets it from frontend.sad.min_disparity_px"},
    {"max_disparity_px", nullptr, "twocam run sets it from frontend.sad.max_disparity_px"},
};

template <typename O, typename V>
void visitLandmarks(O& o, V& v) {
  TWOCAM_CONFIG_KEY(
      policy, "confirmation rule: consistency | wta-lrc | seen-count | culling | inlier-ratio");
  v.section("tracker",
            "prediction, gating, association, life cycle and caps, every policy",
            [&](V& s) { visitTracker(o.tracker, s); });
  v.section("refine", "multi-view refinement at confirmation (landmarks/refine.h)", [&](V& s) {
    visitRefine(o.refine, s);
  });
  v.section("consistency", "the consistency policy (docs/landmarks.md)", [&](V& s) {
    visitConsistency(o.consistency, s);
  });
  v.section("seen_count", "the seen-count baseline (MRPT CLandmarksMap)", [&](V& s) {
    visitSeenCount(o.seen_count, s);
  });
  v.section("culling", "the culling baseline (ORB-SLAM map point culling)", [&](V& s) {
    visitCulling(o.culling, s);
  });
  v.section("inlier_ratio", "the inlier-ratio baseline (SVO depth seed)", [&](V& s) {
    visitInlierRatio(o.inlier_ratio, s);
  });
  for (const MovedKey& m : kMovedLandmarkKeys) v.moved(m.old_key, m.new_key, m.why);
}

template <typename O, typename V>
void visitMapping(O& o, V& v) {
  TWOCAM_CONFIG_KEY(resolution_m, "edge length of the finest voxel [m]");
  TWOCAM_CONFIG_KEY(max_range_m, "farther landmarks are not inserted [m]");
  TWOCAM_CONFIG_KEY(prob_hit, "occupancy update of a landmark's voxel [-]");
  TWOCAM_CONFIG_KEY(prob_miss, "occupancy update of a voxel a ray passes [-]");
  TWOCAM_CONFIG_KEY(clamp_min, "lower clamp of voxel probabilities [-]");
  TWOCAM_CONFIG_KEY(clamp_max, "upper clamp of voxel probabilities [-]");
  TWOCAM_CONFIG_KEY(occupied_threshold, "a voxel is occupied above this probability [-]");
  TWOCAM_CONFIG_KEY(insert_free_space, "carve free space along each ray [bool]");
}

template <typename O, typename V>
void visitPoseUpdate(O& o, V& v) {
  TWOCAM_CONFIG_KEY(min_landmarks, "fewest inliers for a visual pose [-], in [3, 100000]");
  TWOCAM_CONFIG_KEY(pixel_sigma_px, "observed column and row sigma [px]");
  TWOCAM_CONFIG_KEY(disparity_sigma_px, "observed disparity sigma [px]");
  TWOCAM_CONFIG_KEY(cauchy_sigma, "scale of the Cauchy loss on the stereo residuals [sigma]");
  TWOCAM_CONFIG_KEY(inlier_chi2, "squared normalised residual of an inlier, 3 dof [-]");
  TWOCAM_CONFIG_KEY(planar_sigma_m, "soft planar prior: height change per frame [m]");
  TWOCAM_CONFIG_KEY(planar_sigma_rad, "soft planar prior: roll and pitch change per frame [rad]");
  TWOCAM_CONFIG_KEY(max_iterations, "Gauss-Newton iterations of the solve [-]");
  TWOCAM_CONFIG_KEY(max_observations,
                    "most observations in the solve, an even subset [-]; 0 = all, else >= "
                    "min_landmarks");
}

template <typename O, typename V>
void visitLocalization(O& o, V& v) {
  TWOCAM_CONFIG_KEY(mode, "where the poses come from: odometry | pnp | fused");
  TWOCAM_CONFIG_KEY(estimate_gates,
                    "gate confirmed landmarks by the estimate's covariance (pnp, fused) [bool]");
  v.section("update", "the robust pose update (localization/options.h)", [&](V& s) {
    visitPoseUpdate(o.update, s);
  });
  v.section("slip", "the windowed slip test", [&](V& s) {
    auto& so = o.slip;
    s("window_frames", so.window_frames, "measured steps compared with odometry [-], in [1, 100]");
    s("chi2", so.chi2, "chi-square (3 dof) of an odometry outlier [-]");
  });
  v.section("search", "the slip search (localization/pose_search.h)", [&](V& s) {
    auto& so = o.search;
    s("enabled", so.enabled, "check the prediction and search after a slip (fused) [bool]");
    s("reanchor",
      so.reanchor,
      "also search against the earlier map's unassociated landmarks in view [bool]");
    s("associate_at_step",
      so.associate_at_step,
      "associate at the pose a passing heading's references measured, not the prediction [bool]");
    s("max_slip_m", so.max_slip_m, "largest position error searched, per axis [m]");
    s("max_slip_deg", so.max_slip_deg, "largest heading error searched [deg]");
    s("match_px", so.match_px, "one-to-one match: pixel distance per axis [px]");
    s("match_disparity_px", so.match_disparity_px, "one-to-one match: disparity difference [px]");
    s("trigger_fraction",
      so.trigger_fraction,
      "the prediction holds when this fraction of the reference landmarks match [-]");
    s("local_sigmas",
      so.local_sigmas,
      "the check also tries headings within this many prediction yaw sigmas [-]");
    s("accept_fraction",
      so.accept_fraction,
      "a searched pose explains at least this fraction of the reference landmarks, beyond chance "
      "[-]");
    s("reference_frames",
      so.reference_frames,
      "the reference: landmarks the last this many visual updates used [-]");
    s("ambiguity_ratio",
      so.ambiguity_ratio,
      "refused when a distinct pose explains this fraction of the winner's matches with its own "
      "[-]");
    s("min_reference", so.min_reference, "fewest reference landmarks in view to check [-]");
    s("max_reference", so.max_reference, "most reference landmarks the search uses [-]");
    s("min_matches", so.min_matches, "fewest matches of an accepted pose [-]");
    s("win_ratio", so.win_ratio, "an accepted pose explains this many times the prediction's [-]");
    s("vote_m", so.vote_m, "vote bin: position [m]");
    s("vote_deg", so.vote_deg, "vote bin: heading [deg]");
    s("scored_bins", so.scored_bins, "fullest vote bins scored [-]");
    s("point_bins",
      so.point_bins,
      "fullest single-landmark vote bins scored besides them (0: off) [-]");
    s("ambiguity_sigmas",
      so.ambiguity_sigmas,
      "refused when the winner leads the rival by less than this many sqrt(winner + rival) [-]");
  });
  v.section("pnp", "the vision-only baseline (OpenCV solvePnPRansac)", [&](V& s) {
    auto& po = o.pnp;
    s("reprojection_px", po.reprojection_px, "RANSAC inlier threshold [px]");
    s("iterations", po.iterations, "RANSAC iterations [-]");
  });
}

template <typename O, typename V>
void visitConfig(O& o, V& v) {
  v.section("frontend", "corners and stereo hypotheses (frontend/frontend.h)", [&](V& s) {
    visitFrontend(o.frontend, s);
  });
  v.section("landmarks", "landmark database (landmarks/options.h, docs/landmarks.md)", [&](V& s) {
    visitLandmarks(o.landmarks, s);
  });
  v.section("mapping", "occupancy mapping (mapping/options.h)", [&](V& s) {
    visitMapping(o.mapping, s);
  });
  v.section("localization", "where the poses come from (docs/localization.md)", [&](V& s) {
    visitLocalization(o.localization, s);
  });
  TWOCAM_CONFIG_KEY(seed,
                    "recorded for reproducibility; twocam run draws no random numbers today [-]");
}

#undef TWOCAM_CONFIG_KEY

}  // namespace twocam::pipeline::config_schema
