#include "localization/options.h"

#include <string>

#include "common/options_check.h"

namespace twocam::localization {

const char* modeName(Mode mode) {
  switch (mode) {
    case Mode::kOdometry:
      return "odometry";
    case Mode::kPnp:
      return "pnp";
    case Mode::kFused:
      return "fused";
  }
  return "?";
}

Status parseMode(const std::string& name, Mode* mode) {
  for (Mode m : {Mode::kOdometry, Mode::kPnp, Mode::kFused}) {
    if (name == modeName(m)) {
      *mode = m;
      return Status::ok();
    }
  }
  return Status::error("unknown localization mode '" + name + "'; expected odometry, pnp or fused");
}

Status PnpOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "reprojection_px", reprojection_px, 0.1, 100.0, "px"); !s) return s;
  return checkRange(p + "iterations", iterations, 1, 100000);
}

Status PoseSearchOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "max_slip_m", max_slip_m, 1e-3, 2.0, "m"); !s) return s;
  if (Status s = checkRange(p + "max_slip_deg", max_slip_deg, 0.01, 45.0, "deg"); !s) return s;
  if (Status s = checkRange(p + "match_px", match_px, 0.1, 20.0, "px"); !s) return s;
  if (Status s = checkRange(p + "match_disparity_px", match_disparity_px, 0.1, 20.0, "px"); !s)
    return s;
  if (Status s = checkRange(p + "trigger_fraction", trigger_fraction, 0.0, 1.0); !s) return s;
  if (Status s = checkRange(p + "local_sigmas", local_sigmas, 0.0, 10.0); !s) return s;
  if (Status s = checkRange(p + "accept_fraction", accept_fraction, 0.0, 1.0); !s) return s;
  if (Status s = checkRange(p + "reference_frames", reference_frames, 1, 1000); !s) return s;
  if (Status s = checkRange(p + "ambiguity_ratio", ambiguity_ratio, 0.0, 1.0); !s) return s;
  if (Status s = checkRange(p + "min_reference", min_reference, 3, 100000); !s) return s;
  if (Status s = checkRange(p + "max_reference", max_reference, min_reference, 100000); !s)
    return s;
  if (Status s = checkRange(p + "min_matches", min_matches, 3, 100000); !s) return s;
  if (Status s = checkRange(p + "win_ratio", win_ratio, 1.0, 100.0); !s) return s;
  if (Status s = checkRange(p + "vote_m", vote_m, 1e-3, max_slip_m, "m"); !s) return s;
  if (Status s = checkRange(p + "vote_deg", vote_deg, 0.01, max_slip_deg, "deg"); !s) return s;
  const int64_t span_t = 2 * votePositionHalfBins() + 1;
  const int64_t bins = span_t * span_t * (2 * voteHeadingHalfBins() + 1);
  if (bins > kMaxVoteBins) {
    return Status::error(p + "vote_m = " + std::to_string(vote_m) + " and " + p +
                         "vote_deg = " + std::to_string(vote_deg) +
                         " over max_slip_m = " + std::to_string(max_slip_m) +
                         " and max_slip_deg = " + std::to_string(max_slip_deg) + " give " +
                         std::to_string(bins) + " vote bins; at most " +
                         std::to_string(kMaxVoteBins) + " (coarser bins or a smaller search box)");
  }
  if (Status s = checkRange(p + "scored_bins", scored_bins, 1, 1000); !s) return s;
  if (Status s = checkRange(p + "point_bins", point_bins, 0, 1000); !s) return s;
  return checkRange(p + "ambiguity_sigmas", ambiguity_sigmas, 0.0, 10.0);
}

Status LocalizationOptions::validate() const {
  if (Status s = update.validate("localization.update."); !s) return s;
  if (Status s = slip.validate("localization.slip."); !s) return s;
  if (Status s = search.validate("localization.search."); !s) return s;
  return pnp.validate("localization.pnp.");
}

Status PoseUpdateOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "min_landmarks", min_landmarks, 3, 100000); !s) return s;
  if (Status s = checkRange(p + "pixel_sigma_px", pixel_sigma_px, 1e-3, 100.0, "px"); !s) return s;
  if (Status s = checkRange(p + "disparity_sigma_px", disparity_sigma_px, 1e-3, 100.0, "px"); !s)
    return s;
  if (Status s = checkRange(p + "cauchy_sigma", cauchy_sigma, 0.1, 100.0); !s) return s;
  if (Status s = checkRange(p + "inlier_chi2", inlier_chi2, 0.1, 1e4); !s) return s;
  if (Status s = checkRange(p + "planar_sigma_m", planar_sigma_m, 1e-6, 10.0, "m"); !s) return s;
  if (Status s = checkRange(p + "planar_sigma_rad", planar_sigma_rad, 1e-6, 3.0, "rad"); !s)
    return s;
  if (Status s = checkRange(p + "max_iterations", max_iterations, 1, 1000); !s) return s;
  if (max_observations != 0) {
    return checkRange(p + "max_observations", max_observations, min_landmarks, 1000000);
  }
  return Status::ok();
}

Status SlipTestOptions::validate(const char* prefix) const {
  const std::string p(prefix);
  if (Status s = checkRange(p + "window_frames", window_frames, 1, 100); !s) return s;
  return checkRange(p + "chi2", chi2, 0.1, 1e6);
}

}  // namespace twocam::localization
