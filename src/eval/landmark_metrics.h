#pragma once
/// Evaluation of a landmark run against the simulator's ground truth (docs/conventions.md,
/// "Simulated runs"): hypothesis truth, landmark correctness at the anchor, errors, frames to
/// confirm, and a confidence calibration table. Fed frame by frame beside the pipeline; it keeps
/// only the anchor truth of live landmarks, so memory follows the database's.

#include <cstdint>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

#include "common/features.h"
#include "common/frames.h"
#include "common/rig.h"
#include "common/status.h"
#include "eval/disparity_io.h"
#include "eval/stereo_metrics.h"
#include "io/json.h"
#include "landmarks/landmark_database.h"

namespace twocam::eval {

/// Precision of the landmarks whose confidence is at least a threshold.
struct CalibrationRow {
  double threshold = 0.0;
  int64_t landmarks = 0;  ///< judged landmarks (confirmed or not) at or above the threshold
  int64_t correct = 0;
  double precision = 0.0;  ///< percent; NaN when there are none
};

/// Confirmed landmarks in one texture class of their anchor: the grey-level standard deviation
/// of the 7x7 patch of the left image round the anchor pixel in [min_grey, max_grey).
struct TextureRow {
  const char* name = "";
  double min_grey = 0.0;
  double max_grey = 0.0;
  int64_t confirmed = 0;
  int64_t correct = 0;
  int64_t unjudged = 0;
};

/// Texture classes of TextureRow, in grey levels. A patch of noise alone has the image noise's
/// standard deviation (the simulated worlds: 2 grey levels), so below twice that a patch is
/// plain (a corner there is noise, its match right by chance), up to five times it faint, above
/// it textured.
constexpr double kPlainTextureGrey = 4.0;
constexpr double kFaintTextureGrey = 10.0;
constexpr int kTexturePatchRadius = 3;

/// Grey-level standard deviation of the (2r+1)x(2r+1) patch centred on the pixel nearest (u, v),
/// clipped at the image border [grey levels]. NaN when the pixel is outside the image.
[[nodiscard]] double patchStdDevGrey(const ImageU8& image, double u_px, double v_px, int radius);

struct LandmarkMetrics {
  // hypotheses.*
  int64_t hypotheses_total = 0;
  int64_t hypotheses_judged = 0;          ///< with defined ground truth at their pixel
  double hypotheses_true_fraction = 0.0;  ///< true / judged [0, 1]
  // frontend.*: the salient-mode stereo metrics (stereo_metrics.h, METRICS.md) summed over
  // every frame's points with ground truth: recall_at_k, recall_at_1, and the single-best
  // bad1 / bad2 / avgerr / density after the consistency checks.
  StereoMetrics frontend;
  // landmarks.*
  int64_t confirmed = 0;
  /// Confirmed landmarks that are correct (METRICS.md): judged ones within 1 px of the true
  /// disparity at the anchor, plus unjudged ones on the near or the far surface of their depth
  /// edge (unjudged_near_side + unjudged_far_side, the "Depth edges" rule).
  int64_t correct_confirmed = 0;
  /// Judged correct ones only: every landmark on a depth edge counts as not correct.
  int64_t correct_confirmed_strict = 0;
  /// Distinct physical points among the correct confirmed landmarks: their true 3D points (the
  /// anchor pixel's ray at the true depth, placed with the anchor frame's true pose) merged when
  /// closer than kSamePointM. A policy that confirms the same corner again after losing it
  /// counts each time in correct_confirmed but once here. Counts the judged correct landmarks
  /// (correct_confirmed_strict): one on a depth edge has no single true depth to place it at.
  int64_t correct_distinct_points = 0;
  int64_t unjudged_confirmed = 0;  ///< anchor pixel without defined ground truth (depth edge)
  /// Of the unjudged confirmed landmarks, those that reproject within 1 px of the anchor with a
  /// disparity within 1 px of the nearest (foreground) surface of the anchor's 3x3 neighbourhood,
  /// of the farthest (background) one, or of neither. Diagnostic only: a silhouette corner on the
  /// foreground is a real point, a T-junction of two depths is not, and the 3x3 ground truth
  /// cannot tell them apart. METRICS.md "Depth edges": near and far side are correct (a point on
  /// a real surface), neither is wrong (a mixed depth).
  int64_t unjudged_near_side = 0;
  int64_t unjudged_far_side = 0;
  int64_t unjudged_neither = 0;
  /// Percent of confirmed landmarks that are correct (METRICS.md: correct_confirmed /
  /// confirmed, depth-edge landmarks judged by the near/far rule).
  double precision = 0.0;
  /// correct_confirmed_strict / confirmed: every depth-edge landmark counts as not correct (the
  /// definition of `precision` before 2026-12-02).
  double precision_strict = 0.0;
  /// correct_confirmed_strict over judged landmarks only (anchor with defined ground truth), to
  /// separate wrong depths from corners on depth edges.
  double precision_judged = 0.0;
  double median_error_m = 0.0;
  double p90_error_m = 0.0;
  /// METRICS.md landmarks.map_error_*: distance between each judged confirmed landmark's
  /// position in the robot's world frame and its true point in the true world, with no alignment
  /// beyond the shared start pose [m] (the map as a map: the drift of the poses it was built with
  /// included). NaN when no confirmed landmark has a true point.
  double map_error_median_m = 0.0;
  double map_error_p90_m = 0.0;
  /// METRICS.md landmarks.duplicate_fraction: of the confirmations during the run of landmarks
  /// with a true point (`confirmations_judged`), those (`duplicates`) whose true point, projected
  /// into the true camera of the confirming frame, lies within 1 px in u and v and 1 px of
  /// disparity of the projected true point of an older confirmed landmark still in the database:
  /// that one should have been re-associated. NaN when there were no such confirmations.
  int64_t confirmations_judged = 0;
  int64_t duplicates = 0;
  double duplicate_fraction = 0.0;
  double frames_to_confirm_median = 0.0;
  int64_t candidates = 0;
  /// Live landmarks not created in this run (a saved map's, handed to the tracker after
  /// relocalisation): not judged, not in the counts above or below.
  int64_t restored = 0;
  std::vector<CalibrationRow> calibration;
  /// Confirmed landmarks by the texture at their anchor: plain, faint, textured.
  std::vector<TextureRow> by_texture;
};

/// One confirmation counted in LandmarkMetrics::duplicates, with what the database knew of the
/// older landmark at that point then (run output duplicates.csv: where duplicates come from).
struct DuplicateRecord {
  int32_t frame = 0;         ///< the confirming frame
  uint64_t id = 0;           ///< the landmark confirmed
  int32_t first_frame = -1;  ///< its seeding frame
  /// The older confirmed landmark whose true point is nearest (largest of the u, v, d offsets),
  /// its seeding and confirming frames, and the last frame that associated it (this one
  /// included: equal to `frame` when both were associated in the confirming frame).
  uint64_t older_id = 0;
  int32_t older_first_frame = -1;
  int32_t older_confirmed_frame = -1;
  int32_t older_last_seen_frame = -1;
};

/// A ground-truth pose farther than this from the origin is refused [m]: no simulated or
/// recorded world is that large, and beyond it float positions lose the 2 cm of kSamePointM.
constexpr double kMaxGroundTruthCoordM = 1e6;

/// Error unless the true pose is finite and within kMaxGroundTruthCoordM of the origin.
[[nodiscard]] Status checkGroundTruthPose(const Eigen::Isometry3d& T_w_b_true);

/// Two correct landmarks whose true points are closer than this are one physical point [m]
/// (a Harris corner re-detected from another view lands a pixel or two away: ~6 mm at 3 m).
constexpr double kSamePointM = 0.02;

class LandmarkEvaluator {
 public:
  explicit LandmarkEvaluator(const StereoRig& rig) : rig_(rig) {}

  /// Records the truth of this frame's hypotheses and of the landmarks created in it.
  /// `gt_depth` is the left camera's ground-truth depth of this frame and T_w_b_true the
  /// frame's true body pose (for correct_distinct_points); `left` the left image the frontend
  /// matched (for the texture at new anchors). Errors: a depth image that does not fit the rig,
  /// a true pose that fails checkGroundTruthPose.
  [[nodiscard]] Status addFrame(const StereoHypotheses& hyps,
                                const ImageU8& left,
                                const landmarks::FrameReport& report,
                                const landmarks::LandmarkDatabase& db,
                                const ImageF32& gt_depth,
                                const Eigen::Isometry3d& T_w_b_true);
  /// The same with the landmarks looked up by id (LandmarkDatabase::find): what the evaluator
  /// reads, so tests can hand-build it. Reads report.created_ids and report.removed_ids.
  [[nodiscard]] Status addFrame(const StereoHypotheses& hyps,
                                const ImageU8& left,
                                const landmarks::FrameReport& report,
                                const std::function<const landmarks::Landmark*(uint64_t id)>& find,
                                const ImageF32& gt_depth,
                                const Eigen::Isometry3d& T_w_b_true);

  /// Every confirmation counted as a duplicate so far, in frame order.
  [[nodiscard]] const std::vector<DuplicateRecord>& duplicateRecords() const {
    return duplicate_records_;
  }

  /// Final metrics from the database's final state.
  [[nodiscard]] LandmarkMetrics finish(const landmarks::LandmarkDatabase& db) const;
  [[nodiscard]] LandmarkMetrics finish(const std::vector<landmarks::Landmark>& slots) const;

  /// Ground-truth verdict of a landmark (for pictures and CSV): 1 correct, 0 wrong, -1 unjudged.
  [[nodiscard]] int verdict(const landmarks::Landmark& l) const;
  /// Ground-truth disparity at the landmark's anchor pixel [px] (NaN when unjudged).
  [[nodiscard]] double anchorDisparityGt(const landmarks::Landmark& l) const;
  /// Largest and smallest true disparity over the anchor's 3x3 neighbourhood [px] (NaN when a
  /// neighbour has no surface or the landmark is unknown).
  [[nodiscard]] double anchorDisparityNear(const landmarks::Landmark& l) const;
  [[nodiscard]] double anchorDisparityFar(const landmarks::Landmark& l) const;
  /// Error of a landmark [m] (NaN when unjudged).
  /// Grey-level standard deviation of the 7x7 patch at the anchor (NaN when unknown).
  [[nodiscard]] double anchorTextureGrey(const landmarks::Landmark& l) const;
  [[nodiscard]] double errorM(const landmarks::Landmark& l) const;

 private:
  /// Which surface of its depth edge an unjudged landmark took: it reprojects within 1 px of
  /// its anchor pixel and its disparity is within 1 px of the near (else the far) surface's.
  enum class EdgeSide { kNear, kFar, kNeither };
  [[nodiscard]] EdgeSide edgeSide(const landmarks::Landmark& l) const;

  struct AnchorTruth {
    float d_gt = 0.0f;   ///< ground-truth disparity at the anchor pixel [px]
    float z_gt = 0.0f;   ///< ground-truth depth at the anchor pixel [m]
    bool valid = false;  ///< ground truth defined there
    /// Nearest and farthest surface over the anchor's 3x3 neighbourhood as disparities [px]
    /// (NaN when some neighbour sees no surface): where ground truth is undefined (a depth
    /// edge) they tell which side of the edge a landmark took.
    float d_near = 0.0f;
    float d_far = 0.0f;
    /// patchStdDevGrey at the anchor pixel in the anchor frame's left image [grey levels].
    float texture_grey = 0.0f;
    /// True 3D point of the anchor pixel in the true world frame [m] (valid anchors only).
    Eigen::Vector3f p_true_w = Eigen::Vector3f::Zero();
  };
  /// Counts this frame's confirmations that duplicate an older confirmed landmark (see
  /// LandmarkMetrics::duplicate_fraction) and adds them to confirmed_true_w_.
  void tallyDuplicates(const landmarks::FrameReport& report,
                       const std::function<const landmarks::Landmark*(uint64_t id)>& find,
                       const Eigen::Isometry3d& T_w_b_true);

  StereoRig rig_;
  DisparityGroundTruth gt_;
  std::unordered_map<uint64_t, AnchorTruth> anchors_;
  /// True points of the confirmed landmarks still in the database that have one, by id.
  std::unordered_map<uint64_t, Eigen::Vector3f> confirmed_true_w_;
  int64_t confirmations_judged_ = 0;
  int64_t duplicates_ = 0;
  std::vector<DuplicateRecord> duplicate_records_;
  int64_t hyp_total_ = 0;
  int64_t hyp_judged_ = 0;
  int64_t hyp_true_ = 0;
  SalientTally frontend_;
};

/// Number of distinct points: greedy clustering in the given order, a point within radius_m of
/// an earlier kept point is the same point. Non-finite points are skipped (not counted); any
/// finite point is handled (far ones share the grid's border cells).
int64_t countDistinctPoints(const std::vector<Eigen::Vector3f>& points, double radius_m);

/// JSON object with the METRICS.md keys, nested by prefix: {"hypotheses": {...},
/// "frontend": {...}, "landmarks": {...}, "calibration": [...], "by_texture": [...]}; NaN
/// metrics are null.
[[nodiscard]] io::Json toJson(const LandmarkMetrics& metrics);

}  // namespace twocam::eval
