#include "eval/trajectory_metrics.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace twocam::eval {

namespace {

Status checkTracks(const std::vector<io::TimedPose>& estimate,
                   const std::vector<io::TimedPose>& truth,
                   const char* what) {
  if (estimate.empty()) return Status::error(std::string(what) + ": empty trajectory");
  if (estimate.size() != truth.size()) {
    return Status::error(std::string(what) + ": " + std::to_string(estimate.size()) +
                         " estimated poses but " + std::to_string(truth.size()) + " true ones");
  }
  for (size_t i = 0; i < estimate.size(); ++i) {
    if (estimate[i].t_ns != truth[i].t_ns) {
      return Status::error(std::string(what) + ": pose " + std::to_string(i) + " has time " +
                           std::to_string(estimate[i].t_ns) + " ns, the true one " +
                           std::to_string(truth[i].t_ns) + " ns");
    }
  }
  return Status::ok();
}

}  // namespace

Status ateRmseM(const std::vector<io::TimedPose>& estimate,
                const std::vector<io::TimedPose>& truth,
                double* rmse_m) {
  if (Status st = checkTracks(estimate, truth, "ate"); !st) return st;
  double sum = 0.0;
  for (size_t i = 0; i < estimate.size(); ++i) {
    sum += (estimate[i].T_w_b.translation() - truth[i].T_w_b.translation()).squaredNorm();
  }
  *rmse_m = std::sqrt(sum / static_cast<double>(estimate.size()));
  return Status::ok();
}

Status relativePoseError(const std::vector<io::TimedPose>& estimate,
                         const std::vector<io::TimedPose>& truth,
                         double segment_m,
                         RelativePoseError* rpe) {
  if (!(segment_m > 0.0)) {
    return Status::error("rpe: segment length " + std::to_string(segment_m) + " m is not positive");
  }
  if (Status st = checkTracks(estimate, truth, "rpe"); !st) return st;
  std::vector<double> path(truth.size(), 0.0);
  for (size_t i = 1; i < truth.size(); ++i) {
    path[i] =
        path[i - 1] + (truth[i].T_w_b.translation() - truth[i - 1].T_w_b.translation()).norm();
  }
  double sum_t = 0.0, sum_r = 0.0;
  int64_t pairs = 0;
  size_t j = 0;
  for (size_t i = 0; i < truth.size(); ++i) {
    j = std::max(j, i + 1);
    while (j < truth.size() && path[j] - path[i] < segment_m) ++j;
    if (j >= truth.size()) break;
    const Eigen::Isometry3d d_true = truth[i].T_w_b.inverse() * truth[j].T_w_b;
    const Eigen::Isometry3d d_est = estimate[i].T_w_b.inverse() * estimate[j].T_w_b;
    const Eigen::Isometry3d e = d_true.inverse() * d_est;
    sum_t += e.translation().norm() / segment_m;
    sum_r += Eigen::AngleAxisd(e.rotation()).angle() * 180.0 / M_PI / segment_m;
    ++pairs;
  }
  rpe->pairs = pairs;
  rpe->trans_pct = pairs > 0 ? 100.0 * sum_t / static_cast<double>(pairs) : std::nan("");
  rpe->rot_deg_per_m = pairs > 0 ? sum_r / static_cast<double>(pairs) : std::nan("");
  return Status::ok();
}

}  // namespace twocam::eval
