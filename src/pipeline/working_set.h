#pragma once
/// The tracker's bounded working set (Paper A §5.5.2: the vision system keeps "only a minor
/// amount of landmarks in local storage"; the main computer stores them "and sends them back to
/// the vision system when they will reappear in the visual field"). With `twocam run --map`,
/// confirmed landmarks far from the robot leave the tracker (their rows stay in the map, the
/// landmark store) and come back from the store when the robot nears their place again, before
/// they can be in view. Model and measurements: docs/store.md#working-set.
///
/// The set is the confirmed landmarks within `radius_m` of the robot (on the floor, in the
/// maximum norm: a square of half-side radius_m round it, in the map frame) and at most
/// `max_landmarks` of them, the nearest. A check reads from the store only the strips the square
/// swept since the last check that left every landmark of its square in the tracker. It is kept
/// right after the map recorder commits (every MapRecorderOptions::frames_per_commit frames), so
/// the store holds every row the tracker releases:
///   1. out: the map's landmarks in the tracker that no frame since the last check predicted in
///      view (landmarks::Landmark::last_visible_frame; seen or not) and lie farther than the radius
///      plus `hysteresis_m` leave it; above the count cap the farthest of them leave until
///      `kCapRefill` of the cap remain, and the radius shrinks to the farthest kept (a dense area
///      keeps a smaller set round the robot). What is in view never leaves, so the cap is exceeded
///      when the view alone holds more;
///   2. in: the store's landmarks within the radius that are not in the tracker join it
///      (landmarks::LandmarkDatabase::restoreConfirmed: their gates start from this frame), the
///      nearest first, up to the cap.
/// Landmarks the map does not hold yet (candidates; landmarks confirmed before the run was placed
/// in an extended map) never leave. Without a radius and without a cap nothing is paged.
///
/// Frames: o = the run's world frame (the tracker's), m = the map frame (MapRecorder::T_m_o).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "common/status.h"
#include "landmarks/landmark.h"

namespace twocam::pipeline {

class MapRecorder;
class Pipeline;

struct WorkingSetOptions {
  /// Confirmed landmarks within this distance of the robot (on the floor, maximum norm) stay in
  /// (or come back to) the tracker [m]; 0: no radius. It must exceed the range at which landmarks
  /// are still observed, plus the path between two commits: what is farther cannot be in view
  /// before the next check.
  double radius_m = 0.0;
  /// A landmark leaves only beyond radius_m + hysteresis_m [m], so that one at the border does
  /// not go out and in at every check.
  double hysteresis_m = 1.0;
  /// At most this many of the map's confirmed landmarks in the tracker [-]; 0: no cap. Keep it
  /// below landmarks.tracker.max_confirmed, whose cap forgets (removes) landmarks instead.
  int max_landmarks = 0;
  [[nodiscard]] bool enabled() const { return radius_m > 0.0 || max_landmarks > 0; }
  /// Messages start with "--working-set-".
  [[nodiscard]] Status validate() const;
};

/// What the working set did over a run.
struct WorkingSetStats {
  int64_t checks = 0;
  int64_t paged_out = 0;
  int64_t paged_in = 0;
  /// Index entries the checks read (the ids in the strips the set swept), and the rows among
  /// them they read in full (those the tracker did not hold).
  int64_t ids_read = 0;
  int64_t rows_read = 0;
  /// Most confirmed landmarks in the tracker right after a check.
  int max_confirmed = 0;
  /// The radius in use after the last check [m] (shrunk by the cap; 0 = none yet).
  double radius_m = 0.0;
  /// Wall time of each check (queries, releases, restores) [ms].
  std::vector<float> check_ms;
  /// The checks' wall time by step, summed over the run [ms]: the scan of the tracker's
  /// landmarks, paging out (recorder and tracker), reading the store, paging in.
  double scan_ms = 0.0;
  double out_ms = 0.0;
  double query_ms = 0.0;
  double in_ms = 0.0;
};

class WorkingSet {
 public:
  /// Above the cap the farthest leave until this share of it remains [-], so that a full set
  /// is not trimmed at every check.
  static constexpr double kCapRefill = 0.9;

  explicit WorkingSet(const WorkingSetOptions& options);

  /// One check after frame `frame`, with the robot at `robot_o` (that frame's body position in
  /// the run's world frame). Call between frames, only when recorder->committed(). The landmarks
  /// that left are appended to *paged_out (copies of their last records, for evaluation) when
  /// given.
  [[nodiscard]] Status update(const Eigen::Vector3d& robot_o,
                              int32_t frame,
                              MapRecorder* recorder,
                              Pipeline* pipeline,
                              std::vector<landmarks::Landmark>* paged_out);

  [[nodiscard]] const WorkingSetStats& stats() const { return stats_; }
  [[nodiscard]] const WorkingSetOptions& options() const { return options_; }

 private:
  WorkingSetOptions options_;
  WorkingSetStats stats_;
  /// The radius in use: options_.radius_m, or the cap's once it has trimmed the set [m].
  double radius_m_ = 0.0;
  /// The frame of the last check: landmarks seen after it are in view and stay.
  int32_t last_check_frame_ = -1;
  /// The last check left every row within its square held (no cap cut): its centre and radius.
  bool complete_ = false;
  Eigen::Vector2d complete_center_m_ = Eigen::Vector2d::Zero();
  double complete_radius_m_ = 0.0;
};

}  // namespace twocam::pipeline
