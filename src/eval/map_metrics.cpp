#include "eval/map_metrics.h"

#include <algorithm>
#include <cmath>

#include "common/status.h"
#include "sim/world_distance.h"

namespace twocam::eval {

MapMetrics evaluateMap(const std::vector<mapping::Voxel>& occupied,
                       const sim::World& world,
                       double resolution_m,
                       std::vector<double>* distances_m) {
  TWOCAM_CHECK(resolution_m > 0.0) << "resolution_m = " << resolution_m;
  // METRICS.md: phantom beyond two voxel edges from every surface.
  const double phantom_distance_m = 2.0 * resolution_m;
  MapMetrics m;
  m.occupied = static_cast<int64_t>(occupied.size());
  if (distances_m != nullptr) {
    distances_m->clear();
    distances_m->reserve(occupied.size());
  }
  for (const mapping::Voxel& v : occupied) {
    const double d = sim::distanceToSurfaces(world, v.centre_m);
    if (d > phantom_distance_m) ++m.phantom;
    if (distances_m != nullptr) distances_m->push_back(d);
  }
  m.phantom_fraction =
      m.occupied > 0 ? static_cast<double>(m.phantom) / static_cast<double>(m.occupied) : 0.0;
  return m;
}

namespace {
constexpr int kCellBits = 21;
constexpr int64_t kCellOffset = int64_t{1} << (kCellBits - 1);
constexpr int64_t kCellMask = (int64_t{1} << kCellBits) - 1;

int64_t packCell(int64_t i, int64_t j, int64_t k) {
  return ((i + kCellOffset) & kCellMask) | (((j + kCellOffset) & kCellMask) << kCellBits) |
         (((k + kCellOffset) & kCellMask) << (2 * kCellBits));
}
}  // namespace

int64_t voxelCell(const Eigen::Vector3d& p_m, double resolution_m) {
  return packCell(static_cast<int64_t>(std::floor(p_m.x() / resolution_m)),
                  static_cast<int64_t>(std::floor(p_m.y() / resolution_m)),
                  static_cast<int64_t>(std::floor(p_m.z() / resolution_m)));
}

ObservableVoxels::ObservableVoxels(const StereoRig& rig,
                                   double resolution_m,
                                   double max_range_m,
                                   int stride)
    : rig_(rig), resolution_m_(resolution_m), max_range_m_(max_range_m), stride_(stride) {
  TWOCAM_CHECK(resolution_m > 0.0 && max_range_m > 0.0 && stride > 0)
      << "resolution_m = " << resolution_m << ", max_range_m = " << max_range_m
      << ", stride = " << stride;
}

void ObservableVoxels::addFrame(const ImageF32& depth_left, const Eigen::Isometry3d& T_w_b_true) {
  const Eigen::Isometry3d T_w_cl = T_w_b_true * rig_.T_b_cl;
  for (int v = 0; v < depth_left.height; v += stride_) {
    for (int u = 0; u < depth_left.width; u += stride_) {
      const double z = depth_left(u, v);
      if (!(std::isfinite(z) && z > 0.0)) continue;
      const Eigen::Vector3d p_cl(
          (u - rig_.cx_px) / rig_.fx_px * z, (v - rig_.cy_px) / rig_.fy_px * z, z);
      if (p_cl.norm() > max_range_m_) continue;
      cells_.insert(voxelCell(T_w_cl * p_cl, resolution_m_));
    }
  }
}

void measureCompleteness(const std::vector<mapping::Voxel>& occupied,
                         const ObservableVoxels& observable,
                         MapMetrics* m) {
  const double r = observable.resolutionM();
  std::unordered_set<int64_t> held_cells;
  for (const mapping::Voxel& v : occupied) {
    // A pruned OctoMap node covers (size / r)^3 cells of the finest level.
    const int n = std::max(1, static_cast<int>(std::lround(v.size_m / r)));
    const Eigen::Vector3d corner = v.centre_m - Eigen::Vector3d::Constant(0.5 * v.size_m);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        for (int k = 0; k < n; ++k) {
          held_cells.insert(voxelCell(corner + r * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5), r));
        }
      }
    }
  }
  int64_t held = 0;
  for (int64_t c : observable.cells()) {
    const int64_t i = (c & kCellMask) - kCellOffset;
    const int64_t j = ((c >> kCellBits) & kCellMask) - kCellOffset;
    const int64_t k = ((c >> (2 * kCellBits)) & kCellMask) - kCellOffset;
    bool found = false;
    for (int64_t di = -1; di <= 1 && !found; ++di) {
      for (int64_t dj = -1; dj <= 1 && !found; ++dj) {
        for (int64_t dk = -1; dk <= 1 && !found; ++dk) {
          found = held_cells.count(packCell(i + di, j + dj, k + dk)) > 0;
        }
      }
    }
    held += found ? 1 : 0;
  }
  m->observable = static_cast<int64_t>(observable.cells().size());
  m->held = held;
  m->completeness = m->observable > 0
                        ? static_cast<double>(held) / static_cast<double>(m->observable)
                        : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace twocam::eval
