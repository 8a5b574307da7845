#include "eval/map_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace twocam::eval {
namespace {

/// Distances are differences of metre-scale doubles.
constexpr double kDistanceTol = 1e-12;
constexpr double kResolutionM = 0.05;

/// A 10 m x 10 m floor at z = 0.
sim::World floorWorld() {
  sim::World world;
  sim::Shape floor;
  floor.kind = sim::ShapeKind::kPlane;
  floor.size_m = Eigen::Vector3d(10, 10, 0);
  world.shapes.push_back(floor);
  return world;
}

mapping::Voxel voxelAt(const Eigen::Vector3d& centre_m) {
  mapping::Voxel v;
  v.centre_m = centre_m;
  v.size_m = kResolutionM;
  v.probability = 0.9F;
  return v;
}

TEST(MapMetrics, PhantomBeyondTwoVoxelsFromThePlane) {
  const sim::World world = floorWorld();
  // Heights: on the surface, 1 voxel, just inside 2r, just beyond 2r, 1 m; and one beyond the
  // plane's edge (x = 6: 1 m from the rim) at height 0.
  const std::vector<mapping::Voxel> voxels = {voxelAt({0, 0, 0.025}),
                                              voxelAt({1, 1, 0.05}),
                                              voxelAt({2, 2, 0.099}),
                                              voxelAt({3, 3, -0.101}),
                                              voxelAt({4, 4, 1.0}),
                                              voxelAt({6, 0, 0.0})};
  std::vector<double> distances;
  const MapMetrics m = evaluateMap(voxels, world, kResolutionM, &distances);
  EXPECT_EQ(m.occupied, 6);
  EXPECT_EQ(m.phantom, 3);
  EXPECT_DOUBLE_EQ(m.phantom_fraction, 0.5);
  ASSERT_EQ(distances.size(), voxels.size());
  const double expected[] = {0.025, 0.05, 0.099, 0.101, 1.0, 1.0};
  for (size_t i = 0; i < distances.size(); ++i)
    EXPECT_NEAR(distances[i], expected[i], kDistanceTol) << i;
}

TEST(MapMetrics, ThresholdScalesWithResolution) {
  const sim::World world = floorWorld();
  const std::vector<mapping::Voxel> voxels = {voxelAt({0, 0, 0.15})};
  EXPECT_EQ(evaluateMap(voxels, world, 0.05).phantom, 1);  // 0.15 > 0.10
  EXPECT_EQ(evaluateMap(voxels, world, 0.10).phantom, 0);  // 0.15 <= 0.20
}

TEST(MapMetrics, EmptyMapHasZeroFraction) {
  std::vector<double> distances = {1.0};
  const MapMetrics m = evaluateMap({}, floorWorld(), kResolutionM, &distances);
  EXPECT_EQ(m.occupied, 0);
  EXPECT_EQ(m.phantom, 0);
  EXPECT_EQ(m.phantom_fraction, 0.0);
  EXPECT_TRUE(distances.empty());
}

TEST(MapMetrics, CompletenessCountsObservableCellsHeldWithinOneVoxel) {
  StereoRig rig;  // 640x480, fx 500
  rig.T_b_cl = Eigen::Isometry3d::Identity();
  ImageF32 depth(rig.width_px, rig.height_px, 2.0f);  // a wall 2 m in front of the camera
  ObservableVoxels observable(rig, kResolutionM, 6.0);
  observable.addFrame(depth, Eigen::Isometry3d::Identity());
  ASSERT_GT(observable.cells().size(), 100u);
  // The map holds the wall: every observable cell's neighbourhood.
  std::vector<mapping::Voxel> wall;
  for (int v = 0; v < rig.height_px; v += 2) {
    for (int u = 0; u < rig.width_px; u += 2) {
      wall.push_back(voxelAt(Eigen::Vector3d(
          (u - rig.cx_px) / rig.fx_px * 2.0, (v - rig.cy_px) / rig.fy_px * 2.0, 2.0)));
    }
  }
  MapMetrics m;
  measureCompleteness(wall, observable, &m);
  EXPECT_EQ(m.observable, static_cast<int64_t>(observable.cells().size()));
  EXPECT_DOUBLE_EQ(m.completeness, 1.0);
  // One voxel off is still held (26-neighbourhood); three voxels off is not.
  std::vector<mapping::Voxel> moved = wall;
  for (mapping::Voxel& v : moved) v.centre_m.z() += kResolutionM;
  measureCompleteness(moved, observable, &m);
  EXPECT_DOUBLE_EQ(m.completeness, 1.0);
  for (mapping::Voxel& v : moved) v.centre_m.z() += 2 * kResolutionM;
  measureCompleteness(moved, observable, &m);
  EXPECT_DOUBLE_EQ(m.completeness, 0.0);
  // A pruned node of 4 x 4 x 4 cells holds the cells it covers.
  ObservableVoxels one(rig, kResolutionM, 6.0, 100000);  // stride: only pixel (0, 0)
  one.addFrame(depth, Eigen::Isometry3d::Identity());
  ASSERT_EQ(one.cells().size(), 1u);
  const Eigen::Vector3d p(
      (0 - rig.cx_px) / rig.fx_px * 2.0, (0 - rig.cy_px) / rig.fy_px * 2.0, 2.0);
  mapping::Voxel big = voxelAt(p + Eigen::Vector3d::Constant(1.5 * kResolutionM));
  big.size_m = 4 * kResolutionM;
  measureCompleteness({big}, one, &m);
  EXPECT_DOUBLE_EQ(m.completeness, 1.0);
  // Beyond max_range_m nothing is observable: completeness is absent, not 0.
  ObservableVoxels far(rig, kResolutionM, 1.0);
  far.addFrame(depth, Eigen::Isometry3d::Identity());
  measureCompleteness(wall, far, &m);
  EXPECT_EQ(m.observable, 0);
  EXPECT_TRUE(std::isnan(m.completeness));
}

}  // namespace
}  // namespace twocam::eval
