#pragma once
/// Occupancy map against the simulator's world (docs/conventions.md, "Occupancy"): at map
/// resolution r, an occupied voxel is phantom when its centre is farther than 2r from every
/// surface of the world (sim/world_distance.h).

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <unordered_set>
#include <vector>

#include "common/image.h"
#include "common/rig.h"
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
  /// octomap.completeness in [0, 1]: share of the observable surface voxels (ObservableVoxels)
  /// that the map holds (an occupied voxel within one voxel, 26-neighbourhood); NaN when there
  /// are no observable voxels or it was not measured.
  double completeness = std::numeric_limits<double>::quiet_NaN();
  int64_t observable = 0;  ///< observable surface voxels
  int64_t held = 0;        ///< of those, held by the map
};

/// Integer cell index of a point at resolution r: floor(p / r) per axis, the cells OctoMap uses
/// (its keys are floor(p / r) + 2^15), packed into one 64-bit value (21 bits per axis).
[[nodiscard]] int64_t voxelCell(const Eigen::Vector3d& p_m, double resolution_m);

/// The observable surface voxels of a run (METRICS.md "octomap.completeness"): the cells holding
/// the true 3D points of the simulator's depth pixels, every `stride`-th pixel in each
/// direction, within max_range_m of the camera, over all frames.
class ObservableVoxels {
 public:
  ObservableVoxels(const StereoRig& rig, double resolution_m, double max_range_m, int stride = 4);
  /// Adds one frame: the left camera's true depth image (the rig's size; non-finite or
  /// non-positive depth = no surface) and the frame's true body pose.
  void addFrame(const ImageF32& depth_left, const Eigen::Isometry3d& T_w_b_true);
  [[nodiscard]] const std::unordered_set<int64_t>& cells() const { return cells_; }
  [[nodiscard]] double resolutionM() const { return resolution_m_; }

 private:
  StereoRig rig_;
  double resolution_m_;
  double max_range_m_;
  int stride_;
  std::unordered_set<int64_t> cells_;
};

/// Sets m->completeness, observable and held: the share of `observable` held by `occupied`
/// (voxels of any size, split into cells of the observable set's resolution).
void measureCompleteness(const std::vector<mapping::Voxel>& occupied,
                         const ObservableVoxels& observable,
                         MapMetrics* m);

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
