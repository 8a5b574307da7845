#pragma once
/// Options of the occupancy mapper (OctoMap from confirmed landmarks). Sensor model and the
/// reasons for the defaults: docs/mapping.md.

#include "common/status.h"

namespace twocam::mapping {

/// Limits MappingOptions::validate() enforces (cost grows with (range / resolution)^3).
inline constexpr double kMinResolutionM = 0.02;
inline constexpr double kMaxResolutionM = 10.0;
inline constexpr double kMaxRangeM = 100.0;
/// Most voxels a ray may carve (max_range_m / resolution_m); the default carves 120.
inline constexpr double kMaxRayVoxels = 1000.0;

struct MappingOptions {
  /// Edge length of the finest voxel [m], in [kMinResolutionM, kMaxResolutionM] = [0.02, 10]:
  /// 0.02 m took 285 MB and 20 s on office_n1 (0.01 m: 1.2 GB; 0.001 m exhausted memory).
  double resolution_m = 0.05;
  /// Rays to landmarks farther than this from the camera are not inserted [m]: stereo depth
  /// error grows with the square of the distance. At most kMaxRangeM = 100 and at most
  /// kMaxRayVoxels = 1000 voxels (max_range_m <= 1000 * resolution_m).
  double max_range_m = 6.0;
  /// Occupancy probability update of a voxel holding a landmark (hit) and of a voxel a ray
  /// passes through (miss) [-] (OctoMap's defaults).
  double prob_hit = 0.7;
  double prob_miss = 0.4;
  /// Clamping of the voxel probabilities [-] (OctoMap's defaults).
  double clamp_min = 0.1192;
  double clamp_max = 0.971;
  /// A voxel is occupied when its probability reaches this [-] (OctoMap's isNodeOccupied: >=).
  double occupied_threshold = 0.5;
  /// Carve free space along each ray from the camera to the landmark (true), or mark only the
  /// landmark's voxel (false).
  bool insert_free_space = true;
  [[nodiscard]] Status validate() const;
};

}  // namespace twocam::mapping
