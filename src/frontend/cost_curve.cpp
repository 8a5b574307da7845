#include "frontend/cost_curve.h"

#include <string>

namespace twocam::frontend::internal {

Status checkInputs(const ImageU8& left,
                   const ImageU8& right,
                   const SalientSadOptions& options,
                   const StereoHypotheses* out) {
  if (out == nullptr) return Status::error("out is null");
  if (left.empty() || right.empty()) {
    return Status::error("empty image: left is " + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ", right is " + std::to_string(right.width) +
                         "x" + std::to_string(right.height));
  }
  if (left.width != right.width || left.height != right.height) {
    return Status::error("image sizes differ: left is " + std::to_string(left.width) + "x" +
                         std::to_string(left.height) + ", right is " + std::to_string(right.width) +
                         "x" + std::to_string(right.height));
  }
  const size_t pixels = static_cast<size_t>(left.width) * static_cast<size_t>(left.height);
  if (left.width <= 0 || left.height <= 0 || left.data.size() != pixels ||
      right.data.size() != pixels) {
    return Status::error("image buffer size does not match width x height");
  }
  const Status valid = options.validate();
  if (!valid.isOk()) return valid;
  if (options.max_disparity_px + options.window_width_px > left.width) {
    return Status::error("max_disparity_px + window_width_px = " +
                         std::to_string(options.max_disparity_px + options.window_width_px) +
                         " exceeds the image width " + std::to_string(left.width) +
                         "; no pixel can be matched");
  }
  return Status::ok();
}

int costGate(const SalientSadOptions& options) {
  const double gate = static_cast<double>(options.max_cost_per_px) * options.window_width_px;
  return static_cast<int>(std::min(gate, static_cast<double>(INT_MAX / 2)));
}

}  // namespace twocam::frontend::internal
