#pragma once
/// One occupied cell of the occupancy map, as plain data (no OctoMap types).

#include <Eigen/Core>

namespace twocam::mapping {

struct Voxel {
  /// Centre of the voxel in the world frame [m].
  Eigen::Vector3d centre_m = Eigen::Vector3d::Zero();
  /// Edge length [m].
  double size_m = 0.0;
  /// Occupancy probability in (0, 1) [-].
  float probability = 0.5F;
};

}  // namespace twocam::mapping
