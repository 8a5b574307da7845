#pragma once
/// The outputs of a run's landmark map (`twocam run --map MAP.db`, pipeline/map_session.h):
/// what the relocalisation found, against the log's ground truth when it has it.

#include <vector>

#include "eval/run_evaluator.h"
#include "io/json.h"
#include "io/trajectory.h"
#include "pipeline/map_relocalizer.h"
#include "pipeline/map_session.h"

namespace twocam::eval {

/// metrics.json `relocalization` (`--localize-only`, pipeline/map_relocalizer.h): `frame` (first
/// frame placed in the map, -1 when never), `attempts`, `map_landmarks`, the placement's
/// `inliers`, `verified` and `verified_fraction`, `attempt_ms_median`, `open_ms` (the map opened
/// and read), `placed_ms` (from opening the map to the end of the placing attempt, null when
/// never placed), and against the log's true
/// poses (the map frame being the true world frame of the run that built it) `error_m`,
/// `error_deg` at the placed frame and `ate_rmse_m` of the run's track in the map frame from
/// there; each absent (null) with `absent` saying why when it cannot be computed.
io::Json relocalizationJson(const pipeline::RelocalizationReport& report,
                            const std::vector<io::TimedPose>& truth);

/// Adds the map session's outputs to a run's: with --localize-only metrics.json `relocalization`
/// (relocalizationJson), trajectory_map.tum (the run's poses in the map frame, once placed) and
/// a summary line; when recording, the summary line of what the map holds.
void addMapSessionOutputs(const pipeline::MapSession& session,
                          const std::vector<io::TimedPose>& truth,
                          int processed_frames,
                          RunOutputs* out);

}  // namespace twocam::eval
