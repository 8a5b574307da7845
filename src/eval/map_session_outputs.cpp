#include "eval/map_session_outputs.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "common/stats.h"
#include "eval/trajectory_metrics.h"

namespace twocam::eval {

io::Json relocalizationJson(const pipeline::RelocalizationReport& r,
                            const std::vector<io::TimedPose>& truth) {
  using io::Json;
  using io::numberOrNull;
  std::vector<double> ms = r.attempt_ms;
  Json j = {{"frame", r.frame},
            {"attempts", r.attempts},
            {"map_landmarks", r.map_landmarks},
            {"attempt_ms_median", ms.empty() ? Json(nullptr) : numberOrNull(quantile(ms, 0.5))},
            {"open_ms", numberOrNull(r.open_ms)},
            {"placed_ms", r.frame < 0 ? Json(nullptr) : numberOrNull(r.placed_ms)},
            {"error_m", nullptr},
            {"error_deg", nullptr},
            {"ate_rmse_m", nullptr}};
  if (r.frame < 0) {
    j["absent"] = "never relocalised (last attempt: " +
                  (r.last_reason.empty() ? std::string("none") : r.last_reason) + ")";
    return j;
  }
  j["inliers"] = r.inliers;
  j["restored_landmarks"] = r.restored;
  j["verified"] = r.verified;
  j["verified_fraction"] = numberOrNull(r.verified_fraction);
  const int64_t t = r.map_track.front().t_ns;
  const auto it =
      std::find_if(truth.begin(), truth.end(), [t](const io::TimedPose& p) { return p.t_ns == t; });
  if (it == truth.end()) {
    j["absent"] = "the log has no true pose at the relocalised frame";
    return j;
  }
  const Eigen::Isometry3d E = it->T_w_b.inverse() * r.T_m_b;
  j["error_m"] = numberOrNull((r.T_m_b.translation() - it->T_w_b.translation()).norm());
  j["error_deg"] = numberOrNull(Eigen::AngleAxisd(E.linear()).angle() * 180.0 / M_PI);
  // The true poses of the map track's frames (from the placed frame on).
  const std::vector<io::TimedPose> truth_from(it, truth.end());
  double ate = 0.0;
  if (Status s = ateRmseM(r.map_track, truth_from, &ate); s) {
    j["ate_rmse_m"] = numberOrNull(ate);
  } else {
    j["ate_absent"] = s.message();
  }
  return j;
}

void addMapSessionOutputs(const pipeline::MapSession& session,
                          const std::vector<io::TimedPose>& truth,
                          int processed_frames,
                          RunOutputs* out) {
  const std::string& path = session.path();
  if (const pipeline::RelocalizationReport* rr = session.relocalization()) {
    out->metrics["relocalization"] = relocalizationJson(*rr, truth);
    if (!rr->map_track.empty()) {
      out->text_files.emplace_back(
          "trajectory_map.tum",
          io::toTum(rr->map_track, "the run's poses in the frame of " + path));
    }
    const io::Json& j = out->metrics["relocalization"];
    std::ostringstream line;
    line << std::fixed;
    if (rr->frame < 0) {
      line << "relocalisation: never placed in " << path << " (" << rr->attempts
           << " frames tried)\n";
    } else {
      line << "relocalisation: frame " << rr->frame << " placed in " << path << " (" << rr->inliers
           << " inliers";
      if (j["error_m"].is_number()) {
        line << ", error " << std::setprecision(3) << j["error_m"].get<double>() << " m "
             << std::setprecision(2) << j["error_deg"].get<double>() << " deg";
      }
      line << ")\n";
    }
    out->summary += line.str();
  }
  if (const pipeline::WorkingSetStats* ws = session.workingSet()) {
    // Counts are deterministic (metrics.json); the checks' wall time goes to timing.json.
    out->metrics["working_set"] = {{"checks", ws->checks},
                                   {"paged_out", ws->paged_out},
                                   {"paged_in", ws->paged_in},
                                   {"ids_read", ws->ids_read},
                                   {"rows_read", ws->rows_read},
                                   {"max_confirmed", ws->max_confirmed},
                                   {"final_radius_m", ws->radius_m}};
    std::vector<float> ms = ws->check_ms;
    io::Json t = {{"checks", ms.size()}};
    if (!ms.empty()) {
      std::sort(ms.begin(), ms.end());
      t["check_ms_median"] = ms[ms.size() / 2];
      t["check_ms_max"] = ms.back();
      double sum = 0.0;
      for (float v : ms) sum += v;
      t["per_frame_ms_mean"] = processed_frames > 0 ? sum / processed_frames : 0.0;
    }
    out->timing["working_set"] = t;
    std::ostringstream line;
    line << "working set: " << ws->paged_out << " landmarks paged out to the map, " << ws->paged_in
         << " back in, at most " << ws->max_confirmed << " confirmed in the tracker\n";
    out->summary += line.str();
  }
  const std::string map_line = session.summaryLine(processed_frames);
  if (!map_line.empty()) out->summary += map_line + "\n";
}

}  // namespace twocam::eval
