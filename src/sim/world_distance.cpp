#include "sim/world_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace twocam::sim {
namespace {

/// Distance from q to the boundary of the axis-aligned box [-h, h] (any dimension): outside,
/// the norm of the positive part of |q| - h; inside, the margin to the nearest face.
template <int N>
double distanceToBoxBoundary(const Eigen::Matrix<double, N, 1>& q,
                             const Eigen::Matrix<double, N, 1>& h) {
  const Eigen::Matrix<double, N, 1> d = q.cwiseAbs() - h;
  const double largest = d.maxCoeff();
  if (largest > 0.0) return d.cwiseMax(0.0).norm();
  return -largest;
}

}  // namespace

double distanceToShape(const Shape& shape, const Eigen::Vector3d& p_w) {
  const Eigen::Vector3d p_s = shape.T_w_s.inverse() * p_w;
  switch (shape.kind) {
    case ShapeKind::kPlane: {
      const double dx = std::max(std::abs(p_s.x()) - 0.5 * shape.size_m.x(), 0.0);
      const double dy = std::max(std::abs(p_s.y()) - 0.5 * shape.size_m.y(), 0.0);
      return std::sqrt(dx * dx + dy * dy + p_s.z() * p_s.z());
    }
    case ShapeKind::kBox:
      return distanceToBoxBoundary<3>(p_s, 0.5 * shape.size_m);
    case ShapeKind::kCylinder: {
      // The nearest surface point lies in the half-plane through the axis and p: a rectangle
      // of half-sizes (radius, height / 2) in (radial distance, height about mid-height).
      const double half_height = 0.5 * shape.size_m.z();
      const Eigen::Vector2d q(std::hypot(p_s.x(), p_s.y()), p_s.z() - half_height);
      const Eigen::Vector2d h(shape.size_m.x(), half_height);
      return distanceToBoxBoundary<2>(q, h);
    }
  }
  return std::numeric_limits<double>::infinity();
}

double distanceToSurfaces(const World& world, const Eigen::Vector3d& p_w) {
  double best = std::numeric_limits<double>::infinity();
  for (const Shape& shape : world.shapes) best = std::min(best, distanceToShape(shape, p_w));
  return best;
}

}  // namespace twocam::sim
