#include "eval/map_metrics.h"

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

}  // namespace twocam::eval
