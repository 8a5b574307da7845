#include "mapping/options.h"

#include <cmath>
#include <sstream>

#include "common/options_check.h"

namespace twocam::mapping {
namespace {

Status bad(const char* key, double value, const char* constraint) {
  std::ostringstream msg;
  msg << "mapping." << key << " = " << value << "; must be " << constraint;
  return Status::error(msg.str());
}

bool openUnit(double v) { return std::isfinite(v) && v > 0.0 && v < 1.0; }

}  // namespace

Status MappingOptions::validate() const {
  if (!(std::isfinite(resolution_m) && resolution_m > 0.0)) {
    return bad("resolution_m", resolution_m, "> 0 [m]");
  }
  if (!(std::isfinite(max_range_m) && max_range_m > 0.0)) {
    return bad("max_range_m", max_range_m, "> 0 [m]");
  }
  // Bounds the map can honour in memory and time (measured on office_n1: 0.05 m 150 MB 38 s,
  // 0.02 m 285 MB 20 s, 0.01 m 1.2 GB 43 s; 0.001 m exhausted memory).
  if (Status s =
          checkRange("mapping.resolution_m", resolution_m, kMinResolutionM, kMaxResolutionM, "m");
      !s) {
    return s;
  }
  if (Status s = checkRange("mapping.max_range_m", max_range_m, 0.0, kMaxRangeM, "m"); !s) return s;
  if (!(max_range_m <= kMaxRayVoxels * resolution_m)) {
    std::ostringstream msg;
    msg << "mapping.max_range_m = " << max_range_m << "; must be <= " << kMaxRayVoxels
        << " * resolution_m = " << kMaxRayVoxels * resolution_m << " [m] (voxels carved per ray)";
    return Status::error(msg.str());
  }
  // OctoMap keys have 16 bits per axis: the tree spans +-resolution_m * 2^15 around the origin.
  const double tree_half_extent_m = resolution_m * 32768.0;
  if (!(max_range_m < tree_half_extent_m)) {
    std::ostringstream msg;
    msg << "mapping.max_range_m = " << max_range_m
        << "; must be < resolution_m * 2^15 = " << tree_half_extent_m
        << " [m] (the extent of the octree)";
    return Status::error(msg.str());
  }
  if (!openUnit(prob_hit)) return bad("prob_hit", prob_hit, "in (0, 1) [-]");
  if (!openUnit(prob_miss)) return bad("prob_miss", prob_miss, "in (0, 1) [-]");
  if (!openUnit(clamp_min)) return bad("clamp_min", clamp_min, "in (0, 1) [-]");
  if (!openUnit(clamp_max)) return bad("clamp_max", clamp_max, "in (0, 1) [-]");
  if (!openUnit(occupied_threshold)) {
    return bad("occupied_threshold", occupied_threshold, "in (0, 1) [-]");
  }
  if (!(prob_hit > 0.5)) return bad("prob_hit", prob_hit, "> 0.5 (a hit must raise occupancy) [-]");
  if (!(prob_miss < 0.5))
    return bad("prob_miss", prob_miss, "< 0.5 (a miss must lower occupancy) [-]");
  if (!(clamp_min < occupied_threshold)) {
    std::ostringstream msg;
    msg << "mapping.clamp_min = " << clamp_min
        << "; must be < occupied_threshold = " << occupied_threshold << " [-]";
    return Status::error(msg.str());
  }
  if (!(occupied_threshold < clamp_max)) {
    std::ostringstream msg;
    msg << "mapping.clamp_max = " << clamp_max
        << "; must be > occupied_threshold = " << occupied_threshold << " [-]";
    return Status::error(msg.str());
  }
  return Status::ok();
}

}  // namespace twocam::mapping
