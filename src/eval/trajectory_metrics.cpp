#include "eval/trajectory_metrics.h"

#include <cmath>
#include <string>

namespace twocam::eval {

Status ateRmseM(const std::vector<io::TimedPose>& estimate,
                const std::vector<io::TimedPose>& truth,
                double* rmse_m) {
  if (estimate.empty()) return Status::error("ate: empty trajectory");
  if (estimate.size() != truth.size()) {
    return Status::error("ate: " + std::to_string(estimate.size()) + " estimated poses but " +
                         std::to_string(truth.size()) + " true ones");
  }
  double sum = 0.0;
  for (size_t i = 0; i < estimate.size(); ++i) {
    if (estimate[i].t_ns != truth[i].t_ns) {
      return Status::error("ate: pose " + std::to_string(i) + " has time " +
                           std::to_string(estimate[i].t_ns) + " ns, the true one " +
                           std::to_string(truth[i].t_ns) + " ns");
    }
    sum += (estimate[i].T_w_b.translation() - truth[i].T_w_b.translation()).squaredNorm();
  }
  *rmse_m = std::sqrt(sum / static_cast<double>(estimate.size()));
  return Status::ok();
}

}  // namespace twocam::eval
