#include "common/odometry_noise.h"

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

}  // namespace twocam
