#include "sim/world_distance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "sim/world_io.h"
#include "support/test_paths.h"

namespace twocam::sim {
namespace {

/// Hand-computed distances of metre-scale points through one rigid transform: a few ulps.
constexpr double kDistanceTol = 1e-12;
/// Property trials: surface samples are built in the shape frame and moved by T_w_s.
constexpr double kSurfaceTol = 1e-9;
constexpr int kTrials = 1000;

Shape makeShape(ShapeKind kind, const Eigen::Vector3d& size_m, const Eigen::Isometry3d& T_w_s) {
  Shape s;
  s.kind = kind;
  s.size_m = size_m;
  s.T_w_s = T_w_s;
  return s;
}

Eigen::Isometry3d pose(const Eigen::Vector3d& t_w_s, const Eigen::AngleAxisd& R_w_s) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R_w_s.toRotationMatrix();
  T.translation() = t_w_s;
  return T;
}

TEST(WorldDistance, PlaneAtIdentity) {
  // 2 m x 1 m rectangle in the world x-y plane.
  const Shape plane =
      makeShape(ShapeKind::kPlane, Eigen::Vector3d(2, 1, 0), Eigen::Isometry3d::Identity());
  EXPECT_NEAR(distanceToShape(plane, Eigen::Vector3d(0.3, 0.2, 0.0)), 0.0, kDistanceTol);
  EXPECT_NEAR(distanceToShape(plane, Eigen::Vector3d(0.3, 0.2, 3.0)), 3.0, kDistanceTol);
  EXPECT_NEAR(
      distanceToShape(plane, Eigen::Vector3d(0.3, 0.2, -3.0)), 3.0, kDistanceTol);  // both sides
  EXPECT_NEAR(
      distanceToShape(plane, Eigen::Vector3d(2.0, 0.0, 0.0)), 1.0, kDistanceTol);  // beyond edge
  EXPECT_NEAR(distanceToShape(plane, Eigen::Vector3d(2.0, 1.5, 0.0)),
              std::sqrt(2.0),
              kDistanceTol);  // corner
  EXPECT_NEAR(distanceToShape(plane, Eigen::Vector3d(2.0, 0.0, 1.0)),
              std::sqrt(2.0),
              kDistanceTol);  // edge
}

TEST(WorldDistance, RotatedPlaneIsAWall) {
  // Rotation about y by +90 deg: local x -> world -z, local y -> world y, local z -> world x.
  // A 2 m x 1 m wall in the plane x = 5, spanning z in [0, 2] and y in [-0.5, 0.5].
  const Shape wall = makeShape(
      ShapeKind::kPlane,
      Eigen::Vector3d(2, 1, 0),
      pose(Eigen::Vector3d(5, 0, 1), Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY())));
  EXPECT_NEAR(distanceToShape(wall, Eigen::Vector3d(3, 0, 1)), 2.0, kDistanceTol);
  EXPECT_NEAR(distanceToShape(wall, Eigen::Vector3d(5, 0.2, 1.7)), 0.0, kDistanceTol);
  EXPECT_NEAR(
      distanceToShape(wall, Eigen::Vector3d(5, 0, 4)), 2.0, kDistanceTol);  // above the top edge
  EXPECT_NEAR(distanceToShape(wall, Eigen::Vector3d(6, 2, 1)), std::sqrt(3.25), kDistanceTol);
}

TEST(WorldDistance, BoxFromOutsideAndInside) {
  const Shape box =
      makeShape(ShapeKind::kBox, Eigen::Vector3d(2, 4, 6), Eigen::Isometry3d::Identity());
  EXPECT_NEAR(
      distanceToShape(box, Eigen::Vector3d(0, 0, 0)), 1.0, kDistanceTol);  // centre: nearest face x
  EXPECT_NEAR(distanceToShape(box, Eigen::Vector3d(0.5, 0, 0)), 0.5, kDistanceTol);
  EXPECT_NEAR(distanceToShape(box, Eigen::Vector3d(0, 1.8, 0)), 0.2, kDistanceTol);
  EXPECT_NEAR(
      distanceToShape(box, Eigen::Vector3d(0, 0, 3)), 0.0, kDistanceTol);  // on the top face
  EXPECT_NEAR(distanceToShape(box, Eigen::Vector3d(3, 0, 0)), 2.0, kDistanceTol);
  EXPECT_NEAR(
      distanceToShape(box, Eigen::Vector3d(2, 3, 4)), std::sqrt(3.0), kDistanceTol);  // corner
  EXPECT_NEAR(
      distanceToShape(box, Eigen::Vector3d(2, 3, 0)), std::sqrt(2.0), kDistanceTol);  // edge
}

TEST(WorldDistance, RotatedBox) {
  // Yaw +90 deg: local x -> world y, local y -> world -x. Edge 2 m along world y, 4 m along x.
  const Shape box = makeShape(
      ShapeKind::kBox,
      Eigen::Vector3d(2, 4, 6),
      pose(Eigen::Vector3d(10, 0, 0), Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())));
  // Unrotated this point would be inside, 0.2 m from the y face; rotated it is 0.8 m outside.
  EXPECT_NEAR(distanceToShape(box, Eigen::Vector3d(10, 1.8, 0)), 0.8, kDistanceTol);
  EXPECT_NEAR(distanceToShape(box, Eigen::Vector3d(11.5, 0, 0)), 0.5, kDistanceTol);  // inside
  EXPECT_NEAR(distanceToShape(box, Eigen::Vector3d(12.5, 0, 0)), 0.5, kDistanceTol);  // outside
}

TEST(WorldDistance, CylinderSideCapsAndInside) {
  // Radius 1 m, axis z from 0 to 2 m.
  const Shape cyl =
      makeShape(ShapeKind::kCylinder, Eigen::Vector3d(1, 1, 2), Eigen::Isometry3d::Identity());
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(3, 0, 1)), 2.0, kDistanceTol);
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(0, -3, 1)), 2.0, kDistanceTol);
  EXPECT_NEAR(
      distanceToShape(cyl, Eigen::Vector3d(0, 0, 1)), 1.0, kDistanceTol);  // axis, mid-height
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(0.5, 0, 0.2)),
              0.2,
              kDistanceTol);  // inside, near bottom cap
  EXPECT_NEAR(
      distanceToShape(cyl, Eigen::Vector3d(0, 0.7, 1)), 0.3, kDistanceTol);  // inside, near side
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(0, 0, 5)), 3.0, kDistanceTol);  // above top cap
  EXPECT_NEAR(
      distanceToShape(cyl, Eigen::Vector3d(0.5, 0, -1)), 1.0, kDistanceTol);  // below bottom cap
  EXPECT_NEAR(
      distanceToShape(cyl, Eigen::Vector3d(3, 0, 5)), std::sqrt(13.0), kDistanceTol);  // rim
}

TEST(WorldDistance, RotatedCylinderLiesAlongX) {
  // Rotation about y by +90 deg maps local z to world x: axis from (0,0,0) to (2,0,0).
  const Shape cyl = makeShape(
      ShapeKind::kCylinder,
      Eigen::Vector3d(1, 1, 2),
      pose(Eigen::Vector3d::Zero(), Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY())));
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(1, 0, 3)), 2.0, kDistanceTol);
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(-1, 0, 0)), 1.0, kDistanceTol);
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(1, 0, 0.5)), 0.5, kDistanceTol);
  EXPECT_NEAR(distanceToShape(cyl, Eigen::Vector3d(1.9, 0, 0)), 0.1, kDistanceTol);
}

/// A uniformly drawn point of the shape's surface, in the shape frame.
Eigen::Vector3d sampleSurface(const Shape& s, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::uniform_int_distribution<int> face(0, 5);
  const Eigen::Vector3d h = 0.5 * s.size_m;
  switch (s.kind) {
    case ShapeKind::kPlane:
      return {u(rng) * s.size_m.x(), u(rng) * s.size_m.y(), 0.0};
    case ShapeKind::kBox: {
      // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to
      // left, kept)
      const double pz = u(rng) * s.size_m.z();
      const double py = u(rng) * s.size_m.y();
      const double px = u(rng) * s.size_m.x();
      Eigen::Vector3d p(px, py, pz);
      const int f = face(rng);
      p[f / 2] = (f % 2 == 0 ? 1.0 : -1.0) * h[f / 2];
      return p;
    }
    case ShapeKind::kCylinder: {
      const double a = 2.0 * M_PI * (u(rng) + 0.5);
      const int f = face(rng);
      const double r = f < 4 ? s.size_m.x() : s.size_m.x() * std::sqrt(u(rng) + 0.5);
      const double z = f < 4 ? (u(rng) + 0.5) * s.size_m.z() : (f == 4 ? 0.0 : s.size_m.z());
      return {r * std::cos(a), r * std::sin(a), z};
    }
  }
  return Eigen::Vector3d::Zero();
}

TEST(WorldDistance, PropertySurfacePointsAreAtZeroAndDistanceIsALowerBound) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  const Eigen::Isometry3d T_w_s =
      pose(Eigen::Vector3d(1.0, -2.0, 0.5),
           Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  for (const ShapeKind kind : {ShapeKind::kPlane, ShapeKind::kBox, ShapeKind::kCylinder}) {
    const Shape s = makeShape(kind, Eigen::Vector3d(1.2, 0.8, 1.6), T_w_s);
    for (int trial = 0; trial < kTrials; ++trial) {
      const Eigen::Vector3d q_w = T_w_s * sampleSurface(s, rng);
      ASSERT_NEAR(distanceToShape(s, q_w), 0.0, kSurfaceTol)
          << "kind " << static_cast<int>(kind) << " trial " << trial;
      // The distance is the smallest over the surface: no surface point is closer.
      // named draws: a call's arguments are evaluated in an unspecified order (GCC's, right to
      // left, kept)
      const double oz = u(rng);
      const double oy = u(rng);
      const double ox = u(rng);
      const Eigen::Vector3d p_w = T_w_s.translation() + Eigen::Vector3d(ox, oy, oz);
      ASSERT_LE(distanceToShape(s, p_w), (p_w - q_w).norm() + kSurfaceTol)
          << "kind " << static_cast<int>(kind) << " trial " << trial;
    }
  }
}

TEST(WorldDistance, WorldTakesTheNearestShapeAndEmptyWorldIsInfinitelyFar) {
  World world;
  EXPECT_EQ(distanceToSurfaces(world, Eigen::Vector3d::Zero()),
            std::numeric_limits<double>::infinity());
  world.shapes.push_back(
      makeShape(ShapeKind::kPlane, Eigen::Vector3d(10, 10, 0), Eigen::Isometry3d::Identity()));
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0, 0, 2.5);
  world.shapes.push_back(makeShape(ShapeKind::kPlane, Eigen::Vector3d(10, 10, 0), T));
  EXPECT_NEAR(distanceToSurfaces(world, Eigen::Vector3d(0, 0, 0.4)), 0.4, kDistanceTol);
  EXPECT_NEAR(distanceToSurfaces(world, Eigen::Vector3d(0, 0, 2.0)), 0.5, kDistanceTol);
}

TEST(WorldDistance, ShippedWorldFloorAndCeilingAreShapes) {
  // The renderer draws only world.shapes (plus a background colour): floors and ceilings are
  // plane shapes of the world file, so distanceToSurfaces sees them.
  World world;
  const Status st = loadWorld(test::sourceDir() + "/worlds/office.yaml", &world);
  ASSERT_TRUE(st.isOk()) << st.message();
  EXPECT_NEAR(distanceToSurfaces(world, Eigen::Vector3d(1.5, 2.5, 0.0)), 0.0, kDistanceTol);
  EXPECT_NEAR(distanceToSurfaces(world, Eigen::Vector3d(1.5, 2.5, 2.5)), 0.0, kDistanceTol);
}

}  // namespace
}  // namespace twocam::sim
