#pragma once
/// Euclidean distance from a point to the surfaces of a world (ground truth for the phantom
/// voxel metric, docs/conventions.md "Occupancy"). Shapes are the exact solids of world.h;
/// the renderer draws cylinders as prisms (surfaces.h), which differ from the true cylinder
/// by at most r (1 - cos(pi / n)), under 1 mm for the radii of the shipped worlds.
/// The world has no implicit floor or ceiling: they are plane shapes of the world file.

#include <Eigen/Core>

#include "sim/world.h"

namespace twocam::sim {

/// Distance [m] from p_w (world frame) to the surface of one shape:
/// - kPlane: to the rectangle (both sides);
/// - kBox: to the nearest face, from outside or from inside the solid;
/// - kCylinder: to the side or a cap, from outside or from inside.
double distanceToShape(const Shape& shape, const Eigen::Vector3d& p_w);

/// Smallest distanceToShape over the world's shapes [m]; +infinity when there are none.
double distanceToSurfaces(const World& world, const Eigen::Vector3d& p_w);

}  // namespace twocam::sim
