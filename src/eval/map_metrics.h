#pragma once
/// Occupancy map against the simulator's world (docs/conventions.md, "Occupancy"): at map
/// resolution r, an occupied voxel is phantom when its centre is farther than 2r from every
/// surface of the world (sim/world_distance.h).

#include <cstdint>
#include <vector>

#include "mapping/voxel.h"
#include "sim/world.h"

namespace twocam::eval {

struct MapMetrics {
  /// octomap.occupied: occupied voxels evaluated.
  int64_t occupied = 0;
  /// octomap.phantom: those whose centre is farther than 2 * resolution from every surface.
  int64_t phantom = 0;
  /// octomap.phantom_fraction = phantom / occupied in [0, 1]; 0 when there are no voxels.
  double phantom_fraction = 0.0;
};

/// Counts phantom voxels among `occupied` (e.g. OccupancyMapper::occupiedVoxels(), world
/// frame) at map resolution resolution_m > 0 [m]. When distances_m is given it receives each
/// voxel centre's distance to the nearest surface [m], in the order of `occupied`.
/// Voxels and world must share the world frame: run the mapper on ground-truth poses, or
/// accept that odometry drift shows up as phantom voxels.
MapMetrics evaluateMap(const std::vector<mapping::Voxel>& occupied,
                       const sim::World& world,
                       double resolution_m,
                       std::vector<double>* distances_m = nullptr);

}  // namespace twocam::eval
