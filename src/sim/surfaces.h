#pragma once
/// The world's shapes as flat facets: the exact geometry that is rendered and that ground
/// truth is computed from. Cylinders become prisms with many sides, so rendered images and
/// analytic depth describe the same surface.

#include <Eigen/Core>
#include <random>
#include <vector>

#include "common/image.h"
#include "common/status.h"
#include "sim/world.h"

namespace twocam::sim {

/// A planar parallelogram {p0 + a e1 + b e2 : a, b in [0, 1]} or triangle (a, b >= 0,
/// a + b <= 1) in the world frame, with texture coordinates in [0, 1] at p0, p0 + e1, p0 + e2.
struct Facet {
  Eigen::Vector3d p0 = Eigen::Vector3d::Zero();
  Eigen::Vector3d e1 = Eigen::Vector3d::UnitX();
  Eigen::Vector3d e2 = Eigen::Vector3d::UnitY();
  bool triangle = false;
  Eigen::Vector2d uv0 = Eigen::Vector2d::Zero();
  Eigen::Vector2d uv1 = Eigen::Vector2d::UnitX();
  Eigen::Vector2d uv2 = Eigen::Vector2d::UnitY();
};

/// Facets sharing one texture image (a plane, a box face, a cylinder's side or cap).
struct TexturedMesh {
  int shape_index = -1;
  ImageU8 texture;
  std::vector<Facet> facets;
};

/// Number of sides of the prism that stands for a cylinder of the given radius:
/// about one side per 4 cm of circumference, at least 24, at most 96.
int cylinderSegments(double radius_m);

/// Tessellates every shape and rasterises its textures (random ones from rng, in shape
/// order, so the same seed gives the same textures). Fails when a texture file is unreadable.
Status buildMeshes(const World& world, std::mt19937_64& rng, std::vector<TexturedMesh>* meshes);

/// Distance along the ray origin + t * dir (t > 0) at which it hits the facet, or a negative
/// value when it misses. dir need not be normalised; t is in units of |dir|.
double intersectFacet(const Facet& facet,
                      const Eigen::Vector3d& origin,
                      const Eigen::Vector3d& dir);

}  // namespace twocam::sim
