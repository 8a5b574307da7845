#include "localization/options.h"

#include <string>

#include "common/options_check.h"

namespace twocam::localization {

Status PoseUpdateOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "min_landmarks", min_landmarks, 3, 100000); !s) return s;
  if (Status s = checkRange(p + "pixel_sigma_px", pixel_sigma_px, 1e-3, 100.0, "px"); !s) return s;
  if (Status s = checkRange(p + "disparity_sigma_px", disparity_sigma_px, 1e-3, 100.0, "px"); !s)
    return s;
  if (Status s = checkRange(p + "huber_sigma", huber_sigma, 0.1, 100.0); !s) return s;
  if (Status s = checkRange(p + "inlier_chi2", inlier_chi2, 0.1, 1e4); !s) return s;
  if (Status s = checkRange(p + "planar_sigma_m", planar_sigma_m, 1e-6, 10.0, "m"); !s) return s;
  if (Status s = checkRange(p + "planar_sigma_rad", planar_sigma_rad, 1e-6, 3.0, "rad"); !s)
    return s;
  return checkRange(p + "max_iterations", max_iterations, 1, 1000);
}

Status SlipTestOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "window_frames", window_frames, 1, 100); !s) return s;
  return checkRange(p + "chi2", chi2, 0.1, 1e6);
}

}  // namespace twocam::localization
