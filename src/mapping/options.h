#pragma once
/// Options of the occupancy mapper (OctoMap from confirmed landmarks). Sensor model and the
/// reasons for the defaults: docs/mapping.md.

#include "common/status.h"

namespace twocam::mapping {

struct MappingOptions {
  /// Edge length of the finest voxel [m].
  double resolution_m = 0.05;
  /// Rays to landmarks farther than this from the camera are not inserted [m]: stereo depth
  /// error grows with the square of the distance.
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
