#include "common/odometry_noise.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace twocam {

Status OdometryNoise::validate(const char* prefix) const {
  const std::pair<const char*, double> fields[] = {
      {"trans_sigma_per_sqrt_m", trans_sigma_per_sqrt_m},
      {"trans_scale_sigma", trans_scale_sigma},
      {"rot_sigma_per_sqrt_rad", rot_sigma_per_sqrt_rad},
      {"rot_scale_sigma", rot_scale_sigma},
      {"rot_sigma_per_m", rot_sigma_per_m}};
  for (const auto& [name, value] : fields) {
    if (!(value >= 0.0 && value <= 1.0)) {
      std::ostringstream msg;
      msg << prefix << name << " = " << value << "; must be in [0, 1]";
      return Status::error(msg.str());
    }
  }
  return Status::ok();
}

OdometryErrorSigma accumulatedOdometrySigma(const OdometryNoise& noise,
                                            double path_m,
                                            double turn_rad) {
  const double s = std::max(0.0, path_m);
  const double th = std::abs(turn_rad);
  OdometryErrorSigma out;
  out.trans_m = noise.trans_sigma_per_sqrt_m * std::sqrt(s) + noise.trans_scale_sigma * s;
  out.yaw_rad = noise.rot_sigma_per_sqrt_rad * std::sqrt(th) + noise.rot_scale_sigma * th +
                noise.rot_sigma_per_m * s;
  return out;
}

}  // namespace twocam
